//! The `meshrad` command line; all the work is in the library.

fn main() -> std::process::ExitCode {
    meshrad::cli::main()
}
