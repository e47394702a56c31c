#!/usr/bin/env bash
# Evaluates momo and the in-tool 5-point baselines on every simulated scenario.
#
# Usage: scripts/sim_eval.sh [OUT_DIR] [SECTION.md] [IMG_DIR]
#   OUT_DIR     sequences, estimates and scores; default target/sim_eval
#   SECTION.md  the Markdown section written; default OUT_DIR/sim.md
#   IMG_DIR     the pictures (PNG); default OUT_DIR/img. Links in SECTION.md are relative to
#               IMG_DIR's parent if IMG_DIR is docs/img (docs/RESULTS.md), absolute otherwise.
#   SEEDS       environment variable: simulation seeds (default "1 2 3")
#   FRAMES      environment variable: frames per sequence (default 400)
#
# Every scenario of `momo simulate --help` is simulated for each seed; `momo run` runs the
# default configuration (`momo`), `--estimator five-point` (OpenCV-style 5-point RANSAC +
# cheirality) and `--estimator five-point-refined` (the same with LO-RANSAC-style refinement),
# all with the odometry arc length; `momo eval` scores each. Pictures (seed 1): trajectories
# from above and frame-to-frame rotation errors over path length and speed, per scenario; the
# cost landscape (yaw x arc length) of one frame of the fisheye surround rig.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
out="$(abs "${1:-$root/target/sim_eval}")"
section="$(abs "${2:-$out/sim.md}")"
img="$(abs "${3:-$out/img}")"
seeds="${SEEDS:-1 2 3}"
frames="${FRAMES:-400}"
scenarios="clean_pinhole outliers sparse_outliers very_sparse moving_object fisheye_surround highway"
estimators="momo momo_no_prior momo_se3 momo_tukey five_point five_point_refined"

(cd "$root" && cargo build --release)
momo="$root/target/release/momo"
mkdir -p "$out/seq" "$out/est" "$img"
# momo_se3: the default before 2026-11-24 (se3, no soft-prior centring, no final stage).
# momo_no_prior: the default without the rotation prior (odometry.rotation_change_sigma = 0).
"$momo" config |
    sed -e '/^side_slip_sigma = /d' -e '/^climb_sigma = /d' \
        -e 's/^type = "soft_single_track"/type = "se3"/' \
        -e 's/^soft_prior_centring_frames = .*/soft_prior_centring_frames = 0/' \
        -e 's/^enabled = true/enabled = false/' >"$out/momo_se3.toml"
"$momo" config | sed -e 's/^rotation_change_sigma = .*/rotation_change_sigma = 0.0/' \
    >"$out/momo_no_prior.toml"
# momo_tukey: the default, then each frame refined with Tukey at 0.0075 rad ([refine_loss]).
{ "$momo" config; printf '\n[refine_loss]\ntype = "tukey"\nscale = 0.0075\n'; } >"$out/momo_tukey.toml"
# Links: relative when the pictures sit in docs/img (RESULTS.md lives in docs/).
if [[ "$img" == "$root/docs/img" ]]; then link="img"; else link="$img"; fi

mean_time() { # DIAG.csv -> mean time_us
    awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "time_us") c = i; next }
             { s += $c; n++ } END { if (n) printf "%.0f", s / n }' "$1"
}

rows="$out/rows.tsv"
: >"$rows"
for sc in $scenarios; do
    for seed in $seeds; do
        seq="$out/seq/${sc}_s$seed"
        rm -rf "$seq"
        "$momo" simulate --scenario "$sc" --frames "$frames" --seed "$seed" "$seq" >/dev/null
        for e in $estimators; do
            est="$out/est/${sc}_s${seed}__$e.txt"
            diag="$out/est/${sc}_s${seed}__$e.csv"
            how=()
            case "$e" in
                five_point) how=(--estimator five-point) ;;
                five_point_refined) how=(--estimator five-point-refined) ;;
                momo_se3) how=(-c "$out/momo_se3.toml") ;;
                momo_no_prior) how=(-c "$out/momo_no_prior.toml") ;;
                momo_tukey) how=(-c "$out/momo_tukey.toml") ;;
            esac
            if ! "$momo" run "$seq" -o "$est" -d "$diag" "${how[@]}" -q; then
                printf '%s\t%s\t%s\tfailed\n' "$sc" "$seed" "$e" >>"$rows"
                continue
            fi
            # eval's last line: t_err r_err median p95 max >1deg path
            "$momo" eval --gt "$seq/poses.txt" --est "$est" | tail -n 1 |
                awk -v sc="$sc" -v seed="$seed" -v e="$e" -v t="$(mean_time "$diag")" \
                    '{ printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n", sc, seed, e, $3, $4, $5, $6, $1, $2, t }' \
                    >>"$rows"
        done
    done
    # Pictures of seed 1 (the first seed).
    first="${seeds%% *}"
    base="$out/est/${sc}_s${first}__"
    for e in $estimators; do cp "$base$e.txt" "$out/est/$e.txt"; done
    ests=()
    for e in $estimators; do ests+=(--est "$out/est/$e.txt"); done
    "$momo" plot trajectory --gt "$out/seq/${sc}_s$first/poses.txt" "${ests[@]}" \
        -o "$img/sim_${sc}_trajectory.png"
    "$momo" plot errors --gt "$out/seq/${sc}_s$first/poses.txt" "${ests[@]}" \
        -o "$img/sim_${sc}_errors.png"
done
for e in $estimators; do rm -f "$out/est/$e.txt"; done
lf=$((frames > 101 ? 100 : frames - 1))
"$momo" plot landscape "$out/seq/fisheye_surround_s${seeds%% *}" --frame "$lf" \
    -o "$img/sim_fisheye_surround_landscape.png"

{
    echo "## Simulated scenarios"
    echo
    echo "Generated by \`scripts/sim_eval.sh\` on $(date -u +%Y-%m-%d) with $("$momo" --version):"
    echo "every scenario of \`momo simulate\`, $frames frames, seeds $seeds; arc length from the"
    echo "odometry for every estimator. \`momo\`: the default configuration (\`soft_single_track\`, the"
    echo "rotation prior 0.002 rad, the final stage \`[odometry.final_fit]\`); \`momo_no_prior\`: the default"
    echo "without the rotation prior; \`momo_se3\`: the default before 2026-11-24 (\`se3\`, no final stage); \`momo_tukey\`:"
    echo "the default, each frame then refined with Tukey at 0.0075 rad (\`[refine_loss]\`); \`five_point\`:"
    echo "\`--estimator five-point\` (OpenCV-style 5-point RANSAC + cheirality, no refinement);"
    echo "\`five_point_refined\`: \`--estimator five-point-refined\` (LO-RANSAC-style refinement)."
    echo "Rotation errors are frame to frame in degrees (mean over seeds of each run's median,"
    echo "p95, max); >1 deg counts frames over all seeds; t_err (%) and r_err (deg/100 m) are the"
    echo "KITTI devkit's (mean over seeds); µs/frame is the mean estimation time (diagnostics)."
    echo
    echo "| scenario | estimator | median | p95 | max | >1 deg | t_err % | r_err deg/100m | µs/frame |"
    echo "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    awk -F'\t' '$4 == "failed" { f[$1 "|" $3]++; next }
        { k = $1 "|" $3; if (!(k in n)) order[++m] = k
          n[k]++; med[k] += $4; p95[k] += $5; mx[k] += $6; g[k] += $7
          t[k] += $8; r[k] += $9; us[k] += $10 }
        END { for (i = 1; i <= m; i++) { k = order[i]; split(k, a, "|")
            printf "| %s | %s | %.4f | %.4f | %.4f | %d | %.3f | %.3f | %.0f |\n", a[1], a[2],
                med[k] / n[k], p95[k] / n[k], mx[k] / n[k], g[k], t[k] / n[k], r[k] / n[k],
                us[k] / n[k] } }' "$rows"
    echo
    echo "Per seed:"
    echo
    echo "| scenario | seed | estimator | median | p95 | max | >1 deg | t_err % | r_err deg/100m |"
    echo "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |"
    awk -F'\t' '{ if ($4 == "failed") printf "| %s | %s | %s | failed | | | | | |\n", $1, $2, $3;
        else printf "| %s | %s | %s | %.4f | %.4f | %.4f | %s | %s | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8, $9 }' "$rows"
    echo
    echo "### Pictures (seed ${seeds%% *})"
    echo
    for sc in $scenarios; do
        echo "**$sc**: trajectories from above; rotation error over path length and over speed."
        echo
        echo "![$sc trajectory]($link/sim_${sc}_trajectory.png)"
        echo "![$sc rotation errors]($link/sim_${sc}_errors.png)"
        echo
    done
    echo "**fisheye_surround**, frame $lf: the cost over yaw x arc length around momo's estimate."
    echo
    echo "![fisheye_surround landscape]($link/sim_fisheye_surround_landscape.png)"
} >"$section"
echo "sim_eval: wrote $section" >&2
