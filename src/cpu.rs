//! caustica's x86-64 builds may use the extensions of x86-64-v2 (`.cargo/config.toml`), or more when
//! built with `RUSTFLAGS='-C target-cpu=…'`. On a CPU that lacks one of them (an emulator's minimal
//! CPU model, a very old machine, a cluster node older than the one a native build came from) the
//! binary would die with "Illegal instruction" at the first such instruction, with no hint why.
//! `check` compares the extensions the build may use with the ones this CPU has, so that `main` can
//! say which are missing and how to rebuild before anything else of caustica runs. (With fat LTO the
//! standard library's start-up code is compiled with the same extensions; at x86-64-v2 it uses none
//! of them before `main`, checked under QEMU's SSE2-only CPU model; at `target-cpu=native` on an
//! AVX-512 machine it does, and such a binary can still stop before this check.)

/// One extension: its name, whether this build may use it, whether this CPU has it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Feature {
    pub name: &'static str,
    pub compiled: bool,
    pub present: bool,
}

/// What this CPU supports, read from `cpuid` directly: `is_x86_feature_detected!` answers `true` without asking the CPU for every
/// extension the calling code was compiled with, which is exactly what must be asked here.
#[cfg(target_arch = "x86_64")]
struct Cpuid {
    leaf1_ecx: u32,
    leaf7_ebx: u32,
    leaf7_ecx: u32,
    leaf7_1_eax: u32,
    ext1_ecx: u32,
}

#[cfg(target_arch = "x86_64")]
impl Cpuid {
    fn read() -> Cpuid {
        use std::arch::x86_64::__cpuid_count;
        // Leaves above the maximum the CPU reports are not read.
        let (max, max_ext) = (__cpuid_count(0, 0).eax, __cpuid_count(0x8000_0000, 0).eax);
        let leaf = |l: u32, sub: u32, top: u32| (l <= top).then(|| __cpuid_count(l, sub));
        let l1 = leaf(1, 0, max);
        let l7 = leaf(7, 0, max);
        let l7_1 = l7.filter(|r| r.eax >= 1).and_then(|_| leaf(7, 1, max));
        let e1 = leaf(0x8000_0001, 0, max_ext);
        Cpuid {
            leaf1_ecx: l1.map_or(0, |r| r.ecx),
            leaf7_ebx: l7.map_or(0, |r| r.ebx),
            leaf7_ecx: l7.map_or(0, |r| r.ecx),
            leaf7_1_eax: l7_1.map_or(0, |r| r.eax),
            ext1_ecx: e1.map_or(0, |r| r.ecx),
        }
    }

    /// Whether this CPU and OS support extension `name` (a name of `features`).
    fn has(&self, name: &str) -> bool {
        let bit = |reg: u32, b: u32| reg & (1 << b) != 0;
        // The AVX families also need the OS to save their registers. That is XCR0, read by XGETBV,
        // an unsafe intrinsic, and unsafe code lives in `accel` alone: OSXSAVE (the OS manages the
        // extended state at all) stands in for it.
        let avx_state = bit(self.leaf1_ecx, 27);
        let avx512_state = avx_state;
        let (c1, b7, c7) = (self.leaf1_ecx, self.leaf7_ebx, self.leaf7_ecx);
        match name {
            "sse3" => bit(c1, 0),
            "pclmulqdq" => bit(c1, 1),
            "ssse3" => bit(c1, 9),
            "cmpxchg16b" => bit(c1, 13),
            "sse4.1" => bit(c1, 19),
            "sse4.2" => bit(c1, 20),
            "movbe" => bit(c1, 22),
            "popcnt" => bit(c1, 23),
            "aes" => bit(c1, 25),
            "fma" => bit(c1, 12) && avx_state,
            "avx" => bit(c1, 28) && avx_state,
            "f16c" => bit(c1, 29) && avx_state,
            "bmi1" => bit(b7, 3),
            "avx2" => bit(b7, 5) && avx_state,
            "bmi2" => bit(b7, 8),
            "adx" => bit(b7, 19),
            "sha" => bit(b7, 29),
            "avx512f" => bit(b7, 16) && avx512_state,
            "avx512dq" => bit(b7, 17) && avx512_state,
            "avx512ifma" => bit(b7, 21) && avx512_state,
            "avx512cd" => bit(b7, 28) && avx512_state,
            "avx512bw" => bit(b7, 30) && avx512_state,
            "avx512vl" => bit(b7, 31) && avx512_state,
            "avx512vbmi" => bit(c7, 1) && avx512_state,
            "avx512vbmi2" => bit(c7, 6) && avx512_state,
            "gfni" => bit(c7, 8),
            "vaes" => bit(c7, 9) && avx_state,
            "vpclmulqdq" => bit(c7, 10) && avx_state,
            "avx512vnni" => bit(c7, 11) && avx512_state,
            "avx512bitalg" => bit(c7, 12) && avx512_state,
            "avx512vpopcntdq" => bit(c7, 14) && avx512_state,
            "avx512bf16" => bit(self.leaf7_1_eax, 5) && avx512_state,
            "lzcnt" => bit(self.ext1_ecx, 5),
            "sse4a" => bit(self.ext1_ecx, 6),
            _ => false,
        }
    }
}

#[cfg(target_arch = "x86_64")]
macro_rules! feature_table {
    ($($f:tt),* $(,)?) => {
        /// Each extension of `with_extensions!`, with whether this build may use it and whether
        /// this CPU has it.
        pub fn features() -> Vec<Feature> {
            let cpu = Cpuid::read();
            vec![$(Feature { name: $f, compiled: cfg!(target_feature = $f), present: cpu.has($f) }),*]
        }
    };
}

/// The extensions checked, once: every x86-64 extension a `target-cpu` setting can switch on beyond
/// the baseline (SSE2). `with_extensions!(m)` expands to `m!("sse3", …)`.
#[cfg(target_arch = "x86_64")]
macro_rules! with_extensions {
    ($m:ident) => {
        $m! {
            "sse3",
            "ssse3",
            "sse4.1",
            "sse4.2",
            "sse4a",
            "popcnt",
            "cmpxchg16b",
            "avx",
            "avx2",
            "fma",
            "f16c",
            "bmi1",
            "bmi2",
            "lzcnt",
            "movbe",
            "adx",
            "aes",
            "pclmulqdq",
            "sha",
            "gfni",
            "vaes",
            "vpclmulqdq",
            "avx512f",
            "avx512cd",
            "avx512bw",
            "avx512dq",
            "avx512vl",
            "avx512ifma",
            "avx512vbmi",
            "avx512vbmi2",
            "avx512vnni",
            "avx512bitalg",
            "avx512vpopcntdq",
            "avx512bf16"
        }
    };
}

#[cfg(target_arch = "x86_64")]
with_extensions!(feature_table);

/// Other architectures: nothing checked (a build there keeps its target's baseline unless told).
#[cfg(not(target_arch = "x86_64"))]
pub fn features() -> Vec<Feature> {
    Vec::new()
}

/// The extensions in `table` this build may use but this CPU lacks.
pub fn missing(table: &[Feature]) -> Vec<&'static str> {
    table.iter().filter(|f| f.compiled && !f.present).map(|f| f.name).collect()
}

/// Ok on a CPU that has every extension this build may use; else the message to print.
pub fn check(table: &[Feature]) -> Result<(), String> {
    let missing = missing(table);
    if missing.is_empty() {
        return Ok(());
    }
    Err(format!(
        "this caustica binary was compiled for a CPU with {}, which this CPU lacks (it would stop with \
         \"Illegal instruction\"). Rebuild it on this machine (`cargo build --release`), or build for \
         any x86-64 CPU: RUSTFLAGS='-C target-cpu=x86-64' cargo build --release",
        missing.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Built and tested on the same machine: whatever the build may use, this CPU has.
    #[test]
    fn the_build_machine_has_every_extension_the_build_uses() {
        let table = features();
        assert_eq!(missing(&table), Vec::<&str>::new(), "{table:?}");
        assert!(check(&table).is_ok());
    }

    /// The raw `cpuid` reading agrees with the standard library's detection wherever that one really
    /// asks the CPU (extensions this build was not compiled with; for the others it answers `true`).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_cpuid_reading_agrees_with_std_detect() {
        macro_rules! agree {
            ($($f:tt),*) => {$(
                if !cfg!(target_feature = $f) {
                    assert_eq!(Cpuid::read().has($f), std::arch::is_x86_feature_detected!($f), $f);
                }
            )*};
        }
        with_extensions!(agree);
        assert!(!Cpuid::read().has("no-such-extension"));
    }

    /// On a CPU without an extension the build uses, that extension (and only such ones) is named.
    #[test]
    fn a_cpu_without_a_compiled_extension_is_refused_by_name() {
        let table = [
            Feature { name: "avx2", compiled: true, present: true },
            Feature { name: "avx512f", compiled: true, present: false },
            Feature { name: "avx512bw", compiled: true, present: false },
            Feature { name: "sha", compiled: false, present: false },
        ];
        assert_eq!(missing(&table), vec!["avx512f", "avx512bw"]);
        let msg = check(&table).unwrap_err();
        assert!(msg.contains("avx512f, avx512bw") && msg.contains("target-cpu=x86-64'"), "{msg}");
        assert!(!msg.contains("sha") && !msg.contains("avx2,"), "{msg}");
        // The real table flags exactly the extensions this build was compiled with when none is present.
        let absent: Vec<Feature> = features().into_iter().map(|f| Feature { present: false, ..f }).collect();
        let compiled: Vec<&str> = absent.iter().filter(|f| f.compiled).map(|f| f.name).collect();
        assert_eq!(missing(&absent), compiled);
    }
}
