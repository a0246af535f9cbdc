fn main() -> std::process::ExitCode {
    slamlab::cli::main()
}
