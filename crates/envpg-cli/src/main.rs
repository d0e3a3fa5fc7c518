//! `envpg`: the tools for every built-in environment (see the `envpg_cli` library).

fn main() -> std::process::ExitCode {
    envpg_cli::main(envpg_envs::registry())
}
