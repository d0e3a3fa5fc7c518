#!/bin/bash
# Ablation of the `uav` preset: each change of Algorithm 1 reverted alone (to the paper's form),
# κ ∈ {1, 0.85}, seeds 1..3, oracle best of 4 restarts. About 30 minutes on 2 cores.
# Run from the repository root: bash results/ablation/run.sh
set -euo pipefail
declare -A CH=(
  [no-polish]="--set polish_iterations=0"
  [polish-frozen-routing]="--set polish_policy_rounds=0"
  [polish-one-start]="--set polish_candidates=1"
  [polish-as-before]="--set polish_policy_rounds=0 --set polish_candidates=1 --set polish_iterations=60"
  [sigma-0.3]="--set sigma=0.3"
  [actor-pg]="--set actor_update=pg"
  [estimator-sampled]="--set zeta_estimator=sampled"
  [no-explore]="--set explore_episodes=0"
  [critic-init-default]="--set critic_init=default"
  [zeta-input-absolute]="--set zeta_input=absolute"
  [zeta-input-centered]="--set zeta_input=centered"
  [no-clip-no-average]="--set zeta_clip=0 --set zeta_average=0"
  [no-relocate]="--set relocate_every=0"
  [no-loop-backoff]="--set loop_tolerance=1.0"
)
for name in "${!CH[@]}"; do
  # shellcheck disable=SC2086
  # A run that diverges fails alone; its table marks it missing, and the other changes go on.
  cargo run --release --bin envpg -- table --kappas 1,0.85 --seeds 1..3 --restarts 4 ${CH[$name]} \
    --quiet --out "results/ablation/$name" || echo "$name: some runs failed (see above)"
done
