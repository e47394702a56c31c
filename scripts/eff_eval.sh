#!/usr/bin/env bash
# Efficiency (median error / median Cramér-Rao bound) of several configurations on the simulated
# scenarios without moving objects, over seeds (issue 14).
#
# Usage: scripts/eff_eval.sh OUT_DIR NAME=CONFIG.toml... (CONFIG "default": the built-in one)
#   SEEDS      environment variable: seeds (default "1 2 3 4 5")
#   FRAMES     environment variable: frames per sequence (default 300)
#   SCENARIOS  environment variable: default "clean_pinhole highway very_sparse
#              fisheye_surround outliers sparse_outliers"
#   MOMO       environment variable: the momo binary (default target/release/momo)
#
# Writes OUT_DIR/rows.tsv (scenario seed config median bound eff) and prints a Markdown table:
# per scenario and configuration the median of eff over the seeds, and the per-seed values.
# Sequences are kept in OUT_DIR/seq and reused.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:?usage: scripts/eff_eval.sh OUT_DIR NAME=CONFIG...}"
shift
seeds="${SEEDS:-1 2 3 4 5}"
frames="${FRAMES:-300}"
scenarios="${SCENARIOS:-clean_pinhole highway very_sparse fisheye_surround outliers sparse_outliers}"
momo="${MOMO:-$root/target/release/momo}"
mkdir -p "$out/seq" "$out/est"
rows="$out/rows.tsv"
: >"$rows"
for sc in $scenarios; do
    for seed in $seeds; do
        seq="$out/seq/${sc}_s$seed"
        if [[ ! -f "$seq/bound.csv" ]]; then
            rm -rf "$seq"
            "$momo" simulate --scenario "$sc" --frames "$frames" --seed "$seed" "$seq" >/dev/null
        fi
        for spec in "$@"; do
            name="${spec%%=*}"
            cfg="${spec#*=}"
            how=()
            if [[ "$cfg" != default ]]; then how=(--config "$cfg"); fi
            est="$out/est/${sc}_s${seed}__$name.txt"
            if ! "$momo" run "$seq" "${how[@]}" -o "$est" -q; then
                printf '%s\t%s\t%s\tfailed\n' "$sc" "$seed" "$name" >>"$rows"
                continue
            fi
            "$momo" eval --gt "$seq/poses.txt" --est "$est" | tail -n 2 |
                awk -v sc="$sc" -v s="$seed" -v n="$name" '
                    NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
                    { printf "%s\t%s\t%s\t%s\t%s\t%s\n", sc, s, n, $c["median"], $c["bound"], $c["eff"] }' \
                    >>"$rows"
        done
    done
done
echo "| scenario | configuration | median eff | per seed ($seeds) |"
echo "| --- | --- | ---: | --- |"
for sc in $scenarios; do
    for spec in "$@"; do
        name="${spec%%=*}"
        awk -F'\t' -v sc="$sc" -v n="$name" '$1 == sc && $3 == n && $4 != "failed" { v[++k] = $6; s = s sep sprintf("%.2f", $6); sep = " " }
            $1 == sc && $3 == n && $4 == "failed" { s = s sep "failed"; sep = " " }
            END { m = "n/a"
                if (k) { for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
                    m = (k % 2) ? sprintf("%.2f", v[(k + 1) / 2]) : sprintf("%.2f", (v[k / 2] + v[k / 2 + 1]) / 2) }
                printf "| %s | %s | %s | %s |\n", sc, n, m, s }' "$rows"
    done
done
