//! `envpg-launch`: train with Algorithm 1 on any built-in environment (see the `envpg_launch`
//! library for everything else).

fn main() -> std::process::ExitCode {
    envpg_launch::main(envpg_envs::registry())
}
