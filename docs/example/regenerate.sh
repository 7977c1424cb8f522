#!/usr/bin/env bash
# Regenerates docs/example/ from the documented commands: the README's main job (its report,
# plan plots and two SAR images) and `cellsar-planner reproduce` with the figures that need no
# long plans. `cargo test --workspace` checks that the committed files are current
# (tests/tests/example.rs). Run from the repository root.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

cargo run --release -p pipeline --bin cellsar -- run missions/default-30m.toml \
    --scene radar-sim/scenes/default.toml --out "$out/main-job"
dst=docs/example/main-job
rm -rf "$dst"
mkdir -p "$dst/plan" "$dst/images"
cp "$out"/main-job/{report.md,report.json,metrics.json,detections.csv} "$dst/"
cp "$out"/main-job/plan/{summary.json,trajectory.svg,energy.svg,convergence.svg} "$dst/plan/"
for k in 000 015; do
    cp "$out"/main-job/images/aperture_$k.{png,svg} "$dst/images/"
done

cargo run --release -p pipeline --bin cellsar-planner -- reproduce --quick \
    --only 4a,4c,5,6,7,t3 --out "$out/reproduce"
dst=docs/example/reproduce
rm -rf "$dst"
mkdir -p "$dst"
cp "$out"/reproduce/{REPORT.md,plans.json} "$dst/"
# every figure REPORT.md names on its `Figures:` line (tests/tests/docs.rs checks they are here)
figures=$(sed -n 's/^Figures: //p' "$out/reproduce/REPORT.md" | tr -d '`,')
for f in $figures; do
    mkdir -p "$dst/$(dirname "$f")"
    cp "$out/reproduce/$f" "$dst/$f"
done
echo "docs/example regenerated"
