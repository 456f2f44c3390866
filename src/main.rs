//! The `portcullis` binary: parse arguments, call the library, map the outcome to an exit code
//! (0 clean, 1 the level has errors, 2 the tool could not do its job).

mod cli;

use clap::Parser;

fn main() {
    let cli = match cli::Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    std::process::exit(cli::run(cli));
}
