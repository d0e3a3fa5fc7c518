//! `envpg-launch` with the `queues` environment registered: `queues-launch --instance queues`.

fn main() -> std::process::ExitCode {
    envpg_launch::main(envpg_example_queues::registry())
}
