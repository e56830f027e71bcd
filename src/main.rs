//! caustica binary: parse the command line, run, map errors to a message and a non-zero exit code.
use clap::Parser;

fn main() {
    refuse_a_cpu_it_was_not_built_for();
    quiet_on_broken_pipe();
    let cli = caustica::cli::Cli::parse();
    if let Err(e) = caustica::app::run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// `caustica info scene | head -1` closes our stdout early. Rust ignores SIGPIPE, so the next print
/// fails with EPIPE and `println!` panics; every command prints, so this is handled once, here: a
/// failed print to a closed pipe ends the process quietly with 141 (128 + SIGPIPE), as a shell tool
/// killed by SIGPIPE would. Every other panic keeps the default report.
fn quiet_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(141);
        }
        default(info);
    }));
}

/// First thing: on a CPU without the extensions the build may use (x86-64-v2 by `.cargo/config.toml`,
/// or what RUSTFLAGS asked for), say which are missing and how to rebuild, instead of dying on an
/// illegal instruction later. Kept out of line, apart from what `main` does next.
#[inline(never)]
fn refuse_a_cpu_it_was_not_built_for() {
    if let Err(msg) = caustica::cpu::check(&caustica::cpu::features()) {
        eprintln!("error: {msg}");
        std::process::exit(1);
    }
}
