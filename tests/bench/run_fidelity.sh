#!/bin/bash
# tests/bench/run_fidelity.sh (make fidelity): how close the homogenized
# knit comes to the yarn-level knit (issue 21), measured by volknit report.
# For each pattern (relaxed once) and scene of options/:
#   1. the yarn-level reference (volknit yls; cached: rerun only when its
#      command line changes);
#   2. homogenized runs on one mesh: uniform materials g_s = g_v = g over a
#      log grid, the best uniform material searched on the scene's
#      trajectory loss (g_s and g_v apart, as volknit run's best_uniform;
#      the baseline a fit must beat, with the grid's best), and the
#      material fitted on the scene's own frames (training error);
#   3. the materials fitted on the other scenes (held-out error, paper §8.6),
#      beside the best uniform materials searched on those scenes (the
#      baseline each of them must beat held out: "best_uniform_of_<scene>");
#   4. with FID_JOINT=1, one material fitted to the scenes FID_JOINT_SCENES
#      (default: all) at once (-fit_loss trajectory -fit_joint, options
#      FID_JOINT_OPTS) and run on each scene ("fitted_jointly", or
#      "fitted_jointly_held_out" on a scene it was not fitted to);
#   5. with FID_FTOLS (e.g. "1e-2 3e-2 1e-1"), the best uniform and the own
#      fit again at each of those -pd_ftol (default 1e-3): error against
#      run time, for the report's log-log plot;
#   6. volknit report on all of them; a Markdown table on stdout, with
#      per scene each held-out fit against the uniform searched on the
#      fit's own training scene ("held out: ... fit better / uniform better");
#   7. with python3 present, tools/error_scales.py on each scene's best
#      uniform and own fit: how much of the error varies inside a stitch,
#      with the knit's repeat, or with the patch's overall extent.
# Sizes from the environment: FID_PATTERNS (rib1x1), FID_WALES x FID_COURSES
# (8 x 7, about 2K yarn vertices), FID_SCENES (hang stretch drape twist),
# FID_DURATION (0.2 s: the twist's yarn-level run, at dt 0.18 ms, takes
# about 8 minutes on 2 cores, the others about 1.5; FID_DURATION_<scene>
# for one scene, e.g. FID_DURATION_stretch=1 for options/stretch.opts's
# full 50 %, in the directory <scene>_<duration>s), FID_UNIFORM (10 100 1000 10000 Pa), FID_FIT_OPTS,
# FID_MAT_OPTS (material options of the uniform runs and the fits, e.g.
# "-mat_band 0.7,1.5" or "-mat_coupling 3e5 -mat_coupling_nu 1.5,0"), FID_JOINT and FID_JOINT_OPTS (step 4) and FID_TAG (a suffix of the homogenized runs'
# directories, so runs with other material or fit options sit beside them:
# a fit is redone only when its yarn-level data is newer than its material).
# Outputs in out/fidelity (outside tests/out, which make check clears); the
# mesh has one METIS domain per rank (a mesh cached from before 2026-11-27
# has one domain: remove out/fidelity/<pattern>_<W>x<C>/mesh to remake it).
# Cost: the 4 x 4 rib with hang and stretch took 14 min on 2 cores (the hang
# fit 10 of them); at the defaults expect a few hours, mostly the fits.
# Nothing is asserted: the table is the result.
set -u
cd "$(dirname "$0")/../.."
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIEXEC=${MPIEXEC:-mpiexec}
NP=${FID_RANKS:-2}
PATTERNS=${FID_PATTERNS:-rib1x1}
W=${FID_WALES:-8}
C=${FID_COURSES:-7}
SCENES=${FID_SCENES:-hang stretch drape twist}
T=${FID_DURATION:-0.2}
UNIFORM=${FID_UNIFORM:-10 100 1000 10000}
FIT_OPTS=${FID_FIT_OPTS:-}
MAT_OPTS=${FID_MAT_OPTS:-}
TAG=${FID_TAG:-}
JOINT=${FID_JOINT:-0}
JOINT_OPTS=${FID_JOINT_OPTS:--fit_harmonic 1,10 -fit_gn_its 15}
JOINT_SCENES=${FID_JOINT_SCENES:-$SCENES}
FTOLS=${FID_FTOLS:-}
top=out/fidelity
YLS_MODEL=$(sed -n 's/^#define VK_YLS_MODEL "\(.*\)"$/\1/p' include/vkyls.h) # the model bin/volknit was built with
[ -n "$YLS_MODEL" ] || { echo "run_fidelity.sh: VK_YLS_MODEL not found in include/vkyls.h"; exit 1; }
mkdir -p "$top"
cmds="$top/commands"
: > "$cmds"
run() { echo "    $*" >> "$cmds"; "$@"; }
dur() { local v="FID_DURATION_$1"; echo "${!v:-$T}"; }          # a scene's duration
sdir() { if [ "$(dur "$1")" = "$T" ]; then echo "$d/$1"; else echo "$d/$1_$(dur "$1")s"; fi; } # and its directory
json() { sed -n "s/.*\"$2\": \([^,]*\),\{0,1\}$/\1/p" "$1" | head -n "${3:-1}" | tail -n 1; }

# a sim directory with the mesh: $1 dir, then sim options
sim_run() {
  local dir=$1; shift
  mkdir -p "$dir"; cp "$mesh/mesh.h5" "$dir/"
  run $MPIEXEC -n "$NP" bin/volknit sim -o "$dir" "$@" > "$dir/sim.log" 2>&1 || echo "    (failed: see $dir/sim.log)" >> "$cmds"
}

for pat in $PATTERNS; do
  d="$top/${pat}_${W}x${C}"
  mkdir -p "$d"
  if [ ! -s "$d/yarn.h5" ]; then
    run $MPIEXEC -n "$NP" bin/volknit yarn -o "$d" -yarn_pattern "$pat" -yarn_wales "$W" -yarn_courses "$C" -yarn_relax > "$d/yarn.log" 2>&1 || { echo "relaxation failed: $d/yarn.log"; exit 1; }
  fi
  mesh="$d/mesh"
  if [ ! -s "$mesh/mesh.h5" ]; then
    run bin/volknit mesh -o "$mesh" -yarn_h5 "$d/yarn.h5" -dd_domains "$NP" > "$d/mesh.log" 2>&1 || { echo "mesh failed: $d/mesh.log"; exit 1; }
  fi
  for s in $SCENES; do
    ref="$(sdir "$s")/yls"; mkdir -p "$ref"
    want="yls -yarn_h5 $d/yarn.h5 -options_file options/$s.opts -scene_duration $(dur "$s")"
    # remade when its options changed or another yarn-level model made it (yls.json's rod_model)
    if [ ! -s "$ref/yls.h5" ] || [ "$(cat "$ref/stamp" 2>/dev/null)" != "$want" ] || ! grep -qF "\"rod_model\": \"$YLS_MODEL\"" "$ref/yls.json" 2>/dev/null; then
      t0=$(date +%s)
      run $MPIEXEC -n "$NP" bin/volknit yls -o "$ref" -yarn_h5 "$d/yarn.h5" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" > "$ref/yls.log" 2>&1 \
        && echo "$want" > "$ref/stamp" || echo "    (yarn-level run failed: see $ref/yls.log)" >> "$cmds"
      echo "(yarn-level $pat $s: $(( $(date +%s) - t0 )) s)" >&2
    fi
    # the best uniform material: the scan of g, then stage r = 1 (g_s and g_v apart)
    best="$(sdir "$s")/best_uniform$TAG"; mkdir -p "$best"; cp "$mesh/mesh.h5" "$ref/yls.h5" "$best/"
    if [ ! -s "$best/material.h5" ] || [ "$ref/yls.h5" -nt "$best/material.h5" ]; then
      run $MPIEXEC -n "$NP" bin/volknit fit -o "$best" -options_file "options/$s.opts" $MAT_OPTS -fit_loss trajectory -fit_best_uniform -fit_harmonic 1 -fit_gn_its 30 > "$best/fit.log" 2>&1 || echo "    (best uniform search failed: see $best/fit.log)" >> "$cmds"
    fi
    # the fit on this scene's own frames
    fit="$(sdir "$s")/fit$TAG"; mkdir -p "$fit"; cp "$mesh/mesh.h5" "$ref/yls.h5" "$fit/"
    if [ ! -s "$fit/material.h5" ] || [ "$ref/yls.h5" -nt "$fit/material.h5" ]; then
      run $MPIEXEC -n "$NP" bin/volknit fit -o "$fit" -options_file "options/$s.opts" $MAT_OPTS $FIT_OPTS > "$fit/fit.log" 2>&1 || echo "    (fit failed: see $fit/fit.log)" >> "$cmds"
    fi
  done
  joint="$d/joint$TAG"
  [ "$JOINT_SCENES" = "$SCENES" ] || joint="$d/joint_$(echo $JOINT_SCENES | tr ' ' '_')$TAG"
  if [ "$JOINT" = 1 ]; then
    # the first scene's run in the fit's directory, the others by -fit_joint, each under its prefix
    set -- $JOINT_SCENES; first=$1; shift
    dirs=""; scene_opts=(); i=0
    for s in "$@"; do i=$((i + 1)); dirs="$dirs,$(sdir "$s")/yls"; scene_opts+=(-prefix_push "fit_joint${i}_" -options_file "options/$s.opts" -prefix_pop); done
    mkdir -p "$joint"; cp "$mesh/mesh.h5" "$(sdir "$first")/yls/yls.h5" "$joint/"
    if [ ! -s "$joint/material.h5" ] || [ "$(sdir "$first")/yls/yls.h5" -nt "$joint/material.h5" ]; then
      # shellcheck disable=SC2086
      run $MPIEXEC -n "$NP" bin/volknit fit -o "$joint" -options_file "options/$first.opts" $MAT_OPTS $JOINT_OPTS -fit_loss trajectory -fit_joint "${dirs#,}" "${scene_opts[@]}" > "$joint/fit.log" 2>&1 || echo "    (joint fit failed: see $joint/fit.log)" >> "$cmds"
    fi
  fi
  for s in $SCENES; do
    runs=""; labels=""
    for g in $UNIFORM; do
      sim_run "$(sdir "$s")/u$g$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" $MAT_OPTS -mat_gamma_s "$g" -mat_gamma_v "$g"
      runs="$runs,$(sdir "$s")/u$g$TAG"; labels="$labels,uniform_${g}Pa"
    done
    if [ -s "$(sdir "$s")/best_uniform$TAG/material.h5" ]; then
      sim_run "$(sdir "$s")/ubest$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" -mat_file "$(sdir "$s")/best_uniform$TAG/material.h5"
      runs="$runs,$(sdir "$s")/ubest$TAG"; labels="$labels,best_uniform_searched"
    fi
    for f in $SCENES; do # the held-out baseline: the uniform material searched on another scene's data
      [ "$f" != "$s" ] && [ -s "$(sdir "$f")/best_uniform$TAG/material.h5" ] || continue
      sim_run "$(sdir "$s")/ubest_$f$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" -mat_file "$(sdir "$f")/best_uniform$TAG/material.h5"
      runs="$runs,$(sdir "$s")/ubest_$f$TAG"; labels="$labels,best_uniform_of_$f"
    done
    for f in $SCENES; do
      [ -s "$(sdir "$f")/fit$TAG/material.h5" ] || continue
      sim_run "$(sdir "$s")/fit_$f$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" -mat_file "$(sdir "$f")/fit$TAG/material.h5"
      runs="$runs,$(sdir "$s")/fit_$f$TAG"; labels="$labels,fitted_on_$f"
    done
    for ft in $FTOLS; do # error against run time: the best uniform and the own fit at looser PD tolerances
      if [ -s "$(sdir "$s")/best_uniform$TAG/material.h5" ]; then
        sim_run "$(sdir "$s")/ubest_ftol$ft$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" -mat_file "$(sdir "$s")/best_uniform$TAG/material.h5" -pd_ftol "$ft"
        runs="$runs,$(sdir "$s")/ubest_ftol$ft$TAG"; labels="$labels,best_uniform_searched_ftol_$ft"
      fi
      if [ -s "$(sdir "$s")/fit$TAG/material.h5" ]; then
        sim_run "$(sdir "$s")/fit_${s}_ftol$ft$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" -mat_file "$(sdir "$s")/fit$TAG/material.h5" -pd_ftol "$ft"
        runs="$runs,$(sdir "$s")/fit_${s}_ftol$ft$TAG"; labels="$labels,fitted_on_${s}_ftol_$ft"
      fi
    done
    if [ "$JOINT" = 1 ] && [ -s "$joint/material.h5" ]; then
      sim_run "$(sdir "$s")/fit_joint$TAG" -options_file "options/$s.opts" -scene_duration "$(dur "$s")" -mat_file "$joint/material.h5"
      runs="$runs,$(sdir "$s")/fit_joint$TAG"
      case " $JOINT_SCENES " in *" $s "*) labels="$labels,fitted_jointly" ;; *) labels="$labels,fitted_jointly_held_out" ;; esac
    fi
    run bin/volknit report -report_yls "$(sdir "$s")/yls" -report_runs "${runs#,}" -report_labels "${labels#,}" -o "$(sdir "$s")/report$TAG" > "$(sdir "$s")/report$TAG.log" 2>&1 \
      || echo "    (report failed: see $(sdir "$s")/report$TAG.log)" >> "$cmds"
  done
done

echo "REL = RMS distance of the embedded yarns from the yarn-level ones / RMS displacement of the latter from rest, over"
echo "the frames (1: no better than leaving the patch at rest); floor: the best any mesh shape can do on the mesh."
echo "Speed-up: yarn-level wall time per simulated second / the homogenized run's, both on $NP ranks."
[ -n "$MAT_OPTS" ] && echo "Material options of the uniform runs and the fits: $MAT_OPTS"
echo
echo "| pattern | scene | material | REL | floor REL | max error (r) | s per simulated s | speed-up |"
echo "|---|---|---|---|---|---|---|---|"
for pat in $PATTERNS; do
  d="$top/${pat}_${W}x${C}"
  for s in $SCENES; do
    j="$(sdir "$s")/report$TAG/report.json"
    [ -s "$j" ] || { echo "| $pat | $s | (no report: see $(sdir "$s")/report$TAG.log) | | | | | |"; continue; }
    n=$(grep -c '"label"' "$j")
    best=""; bestrel=""; declare -A relof=()
    for i in $(seq 1 "$n"); do
      label=$(json "$j" label "$i" | tr -d '"'); rel=$(json "$j" rel "$i"); fl=$(json "$j" floor_rel "$i"); relof[$label]=$rel
      mx=$(json "$j" max_error_r "$i"); ps=$(json "$j" wall_time_per_simulated_second "$((i + 1))"); sp=$(json "$j" speedup "$i")
      printf '| %s | %s | %s | %.3f | %.3f | %.1f | %.3g | %.0f |\n' "$pat" "$s" "$label" "$rel" "$fl" "$mx" "$ps" "$sp"
      case "$label" in uniform*|best_uniform*) if [ -z "$bestrel" ] || awk "BEGIN{exit !($rel < $bestrel)}"; then best=$label; bestrel=$rel; fi ;; esac
    done
    echo "| $pat | $s | best uniform: $best | $(printf %.3f "$bestrel") | | | | |"
    for f in $SCENES; do # held out: the fit on f against the uniform searched on f, both run on s
      [ "$f" != "$s" ] && [ -n "${relof[fitted_on_$f]:-}" ] && [ -n "${relof[best_uniform_of_$f]:-}" ] || continue
      a=$(printf %.3f "${relof[fitted_on_$f]}"); b=$(printf %.3f "${relof[best_uniform_of_$f]}") # compared as printed
      echo "| $pat | $s | held out: fitted_on_$f against best_uniform_of_$f | $a against $b: $(awk "BEGIN{print ($a < $b) ? \"fit better\" : (($a > $b) ? \"uniform better\" : \"equal\")}") | | | | |"
    done
  done
done
if command -v python3 > /dev/null; then # where the error lives (tools/error_scales.py): a scene's best uniform and its own fit
  echo
  echo "At what scale each scene's best uniform material and own fit miss the yarns (tools/error_scales.py):"
  for pat in $PATTERNS; do
    case $pat in stockinette) rep=1x1 ;; rib1x1) rep=2x1 ;; rib2x2) rep=4x1 ;; garter) rep=1x2 ;; seed) rep=2x2 ;; basketweave) rep=8x8 ;; *) rep=1x1 ;; esac
    d="$top/${pat}_${W}x${C}"
    for s in $SCENES; do
      dir=$(sdir "$s")
      for m in "ubest$TAG" "fit_$s$TAG"; do
        [ -s "$dir/$m/sim.h5" ] && echo "    tools/error_scales.py $dir/yls $dir/$m $W $C $rep" >> "$cmds" && python3 tools/error_scales.py "$dir/yls" "$dir/$m" "$W" "$C" "$rep" | sed 's/^/    /'
      done
    done
  done
fi
echo
echo "Commands:"
cat "$cmds"
