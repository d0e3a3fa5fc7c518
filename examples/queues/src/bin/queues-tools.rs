//! The `envpg` tools with the `queues` environment registered (`queues-tools oracle --instance
//! queues`); `--workers` runs `queues-launch`.

fn main() -> std::process::ExitCode {
    envpg_cli::main_with_launcher(envpg_example_queues::registry(), "queues-launch")
}
