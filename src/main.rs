//! caustica binary: parse the command line, run, map errors to a message and a non-zero exit code.
use clap::Parser;

fn main() {
    let cli = caustica::cli::Cli::parse();
    if let Err(e) = caustica::app::run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
