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

/// What this CPU supports, read from `cpuid` directly: `is_x86_feature_detected!` answers `true`
/// without asking the CPU for every extension the calling code was compiled with, which is exactly
/// what must be asked here.
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

    /// Bit `b` of a `cpuid` register; for an extension of the AVX family (`avx`), also whether the
    /// OS saves the extended registers. That is XCR0, read by XGETBV, an unsafe intrinsic, and unsafe
    /// code lives in `accel` alone: OSXSAVE (leaf 1 ECX bit 27, the OS manages the extended state at
    /// all) stands in for it.
    fn bit(&self, reg: u32, b: u32, avx: bool) -> bool {
        reg & (1 << b) != 0 && (!avx || self.leaf1_ecx & (1 << 27) != 0)
    }
}

/// The extensions checked, written once: every x86-64 extension a `target-cpu` setting can switch on
/// beyond the baseline (SSE2), each with the `cpuid` register and bit that report it and whether it
/// uses the AVX register state. `with_extensions!(m)` expands to `m! { "sse3" => (leaf1_ecx, 0,
/// false), … }`.
#[cfg(target_arch = "x86_64")]
macro_rules! with_extensions {
    ($m:ident) => {
        $m! {
            "sse3" => (leaf1_ecx, 0, false),
            "pclmulqdq" => (leaf1_ecx, 1, false),
            "ssse3" => (leaf1_ecx, 9, false),
            "fma" => (leaf1_ecx, 12, true),
            "cmpxchg16b" => (leaf1_ecx, 13, false),
            "sse4.1" => (leaf1_ecx, 19, false),
            "sse4.2" => (leaf1_ecx, 20, false),
            "movbe" => (leaf1_ecx, 22, false),
            "popcnt" => (leaf1_ecx, 23, false),
            "aes" => (leaf1_ecx, 25, false),
            "avx" => (leaf1_ecx, 28, true),
            "f16c" => (leaf1_ecx, 29, true),
            "bmi1" => (leaf7_ebx, 3, false),
            "avx2" => (leaf7_ebx, 5, true),
            "bmi2" => (leaf7_ebx, 8, false),
            "avx512f" => (leaf7_ebx, 16, true),
            "avx512dq" => (leaf7_ebx, 17, true),
            "adx" => (leaf7_ebx, 19, false),
            "avx512ifma" => (leaf7_ebx, 21, true),
            "avx512cd" => (leaf7_ebx, 28, true),
            "sha" => (leaf7_ebx, 29, false),
            "avx512bw" => (leaf7_ebx, 30, true),
            "avx512vl" => (leaf7_ebx, 31, true),
            "avx512vbmi" => (leaf7_ecx, 1, true),
            "avx512vbmi2" => (leaf7_ecx, 6, true),
            "gfni" => (leaf7_ecx, 8, false),
            "vaes" => (leaf7_ecx, 9, true),
            "vpclmulqdq" => (leaf7_ecx, 10, true),
            "avx512vnni" => (leaf7_ecx, 11, true),
            "avx512bitalg" => (leaf7_ecx, 12, true),
            "avx512vpopcntdq" => (leaf7_ecx, 14, true),
            "avx512bf16" => (leaf7_1_eax, 5, true),
            "lzcnt" => (ext1_ecx, 5, false),
            "sse4a" => (ext1_ecx, 6, false),
        }
    };
}

#[cfg(target_arch = "x86_64")]
macro_rules! feature_table {
    ($($f:tt => ($reg:ident, $b:tt, $avx:tt)),* $(,)?) => {
        /// Each extension of `with_extensions!`, with whether this build may use it and whether
        /// this CPU has it.
        pub fn features() -> Vec<Feature> {
            let cpu = Cpuid::read();
            vec![$(Feature {
                name: $f,
                compiled: cfg!(target_feature = $f),
                present: cpu.bit(cpu.$reg, $b, $avx),
            }),*]
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
         \"Illegal instruction\"). Build it for this CPU: RUSTFLAGS='-C target-cpu=native' cargo build \
         --release, or for any x86-64 CPU: RUSTFLAGS='-C target-cpu=x86-64' cargo build --release \
         (RUSTFLAGS overrides the x86-64-v2 of .cargo/config.toml)",
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
        let table = features();
        let present = |name: &str| table.iter().find(|f| f.name == name).map(|f| f.present);
        macro_rules! agree {
            ($($f:tt => $bits:tt),* $(,)?) => {$(
                if !cfg!(target_feature = $f) {
                    assert_eq!(present($f), Some(std::arch::is_x86_feature_detected!($f)), $f);
                }
            )*};
        }
        with_extensions!(agree);
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
