//! The `portcullis` binary: parse arguments, call the library, map the outcome to an exit code
//! (0 clean, 1 the level has errors, 2 the tool could not do its job).

mod cli;

fn main() {
    // Rust ignores SIGPIPE, so a closed pipe (`portcullis vis big.prt | head`) would make the
    // next print fail; with the default action the process ends quietly, like `cat`.
    #[cfg(unix)]
    // SAFETY: called before any other thread exists; SIG_DFL is always a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    cli::huge_pages::off();
    let cli = match cli::parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    std::process::exit(cli::run(cli));
}
