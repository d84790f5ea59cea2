#!/usr/bin/env bash
# Regenerate the figures of docs/theory/cross-pol-error.md from the reproduction scenarios.
set -euo pipefail
cd "$(dirname "$0")/../.."
E2ESIM=${E2ESIM:-.venv/bin/e2esim}
tmp=$(mktemp -d)
"$E2ESIM" run scenarios/men2021_fig1.yaml -o "$tmp/fig1" --force --no-progress
"$E2ESIM" run scenarios/men2021_tradeoff_over.yaml -o "$tmp/tradeoff" --force --no-progress
cp "$tmp/fig1/backscatter_vs_sweep.png" docs/theory/img/men2021_fig1.png
cp "$tmp/tradeoff/tradeoff.png" docs/theory/img/men2021_tradeoff_over.png
rm -rf "$tmp"
