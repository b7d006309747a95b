//! The `linpd` binary: a thin wrapper over [`linpd_cli::main`].
fn main() -> std::process::ExitCode {
    linpd_cli::main()
}
