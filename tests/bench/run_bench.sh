#!/bin/bash
# tests/bench/run_bench.sh: the benchmarks of `make bench`, printed as
# Markdown tables together with the commands that produced them.  Times
# are wall clock on this machine; nothing here is asserted (the tests
# assert numbers, the benchmarks report them).
set -u
cd "$(dirname "$0")/../.."
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIEXEC=${MPIEXEC:-mpiexec}
out=tests/out/bench
mkdir -p "$out"

run() { echo "    $*" >> "$out/commands"; "$@"; }
. tests/h5same.sh

echo "## Yarn and mesh stages (issue 2 target: mesh stage < 10 s on one core for 1M yarn vertices)"
echo
: > "$out/commands"
run bin/bench/bench_mesh -bench_header -bench_vertices 1e6 -bench_pattern stockinette -bench_write "$out/stockinette"
run bin/bench/bench_mesh -bench_vertices 1e6 -bench_pattern rib1x1 -bench_write "$out/rib1x1"
run bin/bench/bench_mesh -bench_vertices 1e6 -bench_pattern basketweave
run bin/bench/bench_mesh -bench_vertices 1e6 -bench_pattern stockinette -dd_domains 8
run bin/bench/bench_mesh -bench_vertices 1e5 -bench_pattern stockinette
run $MPIEXEC -n 2 bin/bench/bench_mesh -bench_vertices 1e6 -bench_pattern stockinette
echo
echo "Rows produced by (one process each, so 'peak MB' is that run's peak resident set):"
cat "$out/commands"
echo
echo "One rank, one core unless -n 2.  With -n 2 every rank builds the replicated mesh, then keeps its"
echo "layout; times are rank 0's.  'mesh s' is VKMeshSetUp, the sum of the step columns."
echo
echo "Reference, paper Table 1 (Yuan et al. 2024), mesh DOFs / yarn DOFs:"
echo "1x1 rib 38K/66K = 0.58, stockinette 42K/66K = 0.64, montague 48K/85K = 0.56, flame ribbing 60K/88K = 0.68,"
echo "mixed 77K/118K = 0.65 (the paper: n_V is about n_Y/2).  volknit's n_V/n_Y above is the same ratio (3 DOFs each)."

echo
echo "## Homogenized PD simulator (issue 3 target: within 2x of the paper's 85 ms per step, i.e. <= 170 ms, for a"
echo "## 1x1 rib mesh of about 38K DOFs / 79K tets at dt = 1/150 s, on our 2 cores)"
echo
: > "$out/commands"
# the paper's setting: exactly 10 plain PD iterations per step (10 local, 10 global steps)
PD_FIXED="-pd_type pd -pd_max_it 10 -pd_fixed_its"
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_header -bench_steps 15 $PD_FIXED
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 15 $PD_FIXED -pd_global_pc_type columns
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 15 -pd_type lbfgs -pd_max_it 10 -pd_fixed_its
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 15 $PD_FIXED -pd_global_pc_type cholesky -pd_global_pc_factor_mat_solver_type mumps
# converged to the default tolerance (|grad Phi| <= 1e-3 f_scale): the default L-BFGS, and plain PD
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 15
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 15 -pd_type pd -pd_max_it 2000
run $MPIEXEC -n 2 bin/bench/bench_sim $PD_FIXED -pd_global_ksp_type cg -pd_global_pc_type gamg -pd_global_ksp_rtol 1e-8
# the CMS solver (DESIGN §9): CG to 1e-10 preconditioned by two-level CMS, 8 and 32 domains
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 5 $PD_FIXED -pd_global_pc_type cms -dd_domains 8
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 5 $PD_FIXED -pd_global_pc_type cms -dd_domains 32
run $MPIEXEC -n 1 bin/bench/bench_sim $PD_FIXED
run $MPIEXEC -n 1 bin/bench/bench_sim $PD_FIXED -pd_global_pc_type columns
run $MPIEXEC -n 1 bin/bench/bench_sim $PD_FIXED -pd_global_pc_type cholesky -pd_global_pc_factor_mat_solver_type mumps
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED -pd_global_pc_type columns
# the rest of issue 22's side by side: distributed MUMPS, CG + GAMG and cms at 95 x 95, and one rank at both sizes
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED -pd_global_pc_type cholesky -pd_global_pc_factor_mat_solver_type mumps
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED -pd_global_ksp_type cg -pd_global_pc_type gamg -pd_global_ksp_rtol 1e-8
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 1 $PD_FIXED -pd_global_pc_type cms -dd_domains 512
run $MPIEXEC -n 1 bin/bench/bench_sim $PD_FIXED -pd_global_ksp_type cg -pd_global_pc_type gamg -pd_global_ksp_rtol 1e-8
run $MPIEXEC -n 1 bin/bench/bench_sim -bench_steps 5 $PD_FIXED -pd_global_pc_type cms -dd_domains 32
run $MPIEXEC -n 1 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED
run $MPIEXEC -n 1 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED -pd_global_pc_type cholesky -pd_global_pc_factor_mat_solver_type mumps
run $MPIEXEC -n 1 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 $PD_FIXED -pd_global_ksp_type cg -pd_global_pc_type gamg -pd_global_ksp_rtol 1e-8
# the default L-BFGS to the default tolerance, direct (subtrees) against one two-level CMS cycle as K^-1
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_steps 5 -pd_global_pc_type cms -dd_domains 32
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 95 -bench_courses 95 -bench_steps 2 -pd_global_pc_type cms -dd_domains 512
if [ "${BENCH_LARGE:-0}" = 1 ]; then # about 2M DOFs, 3 min
  run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 175 -bench_courses 175 -bench_steps 2
  run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 175 -bench_courses 175 -bench_steps 2 -pd_global_pc_type cms -dd_domains 2048
  run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 175 -bench_courses 175 -bench_steps 2 -pd_global_pc_type cholesky -pd_global_pc_factor_mat_solver_type mumps
  run $MPIEXEC -n 2 bin/bench/bench_sim -bench_wales 175 -bench_courses 175 -bench_steps 2 -pd_global_ksp_type cg -pd_global_pc_type gamg -pd_global_ksp_rtol 1e-8
fi
echo
echo "Rows produced by:"
cat "$out/commands"
echo
echo "A hanging patch (gravity, top edge held), 1 kPa, from rest.  'its/step' is the mean; the residual is"
echo "|grad Phi| relative to the force scale f_scale (weight + handle reaction), the largest over the steps (the default"
echo "tolerance is 1e-3); 'not measured' for -pd_fixed_its.  'ns/tet/local step' is"
echo "core time per tet per local step (wall time x ranks).  Reference: paper Table 1, 1x1 rib, 85 ms per step on"
echo "an RTX 3090 (38K mesh DOFs).  'subtrees cholmod': the default global solver on up to 3 ranks (PC subtrees,"
echo "one CHOLMOD factor split over the ranks along its elimination tree, every rank solving its subtrees for x, y"
echo "and z); 'columns cholmod': PC columns (every rank factors all of K and solves its share of the x, y, z"
echo "columns); 'cholesky mumps': one distributed MUMPS factor."

echo
echo "## PD set-up after a material change (issue 22 target: with PC cms, a change in one domain of 16 at least"
echo "## 5x faster than refactorization)"
echo
: > "$out/commands"
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_header -bench_material_changes 4 -dd_domains 16 -pd_global_pc_type cms
run $MPIEXEC -n 2 bin/bench/bench_sim -bench_material_changes 4 -dd_domains 16
echo
echo "Rows produced by:"
cat "$out/commands"
echo
echo "The 30x30 rib's hang; every g of domain 0's tets scaled by 1.1 (then back), 4 times, then every tet's, 4"
echo "times; the PD set-up (assembly of K and the global PC's set-up) averaged.  'first set-up' builds everything"
echo "(with cms: every domain's factor, boundary and interior modes, and K_r); 'domains rebuilt' is what cms"
echo "found changed.  subtrees (the default) refactors CHOLMOD numerically on every change."

echo
echo "## Yarn-level simulator, discrete elastic rods (issue 23 targets: the 2K rib stretch at no more than 8 Newton"
echo "## iterations per step; the 22K rib stretch, 30 steps, at no more than 600 s of wall time per simulated second"
echo "## on our 2 cores)"
echo
: > "$out/commands"
# One relaxation per patch (volknit yarn -yarn_relax), timed apart; then short runs of two scenes from it.
yls_relaxed() { # wales courses -> directory with the relaxed yarn.h5
  d="$out/yls_rib$1x$2"
  mkdir -p "$d"
  run $MPIEXEC -n 2 bin/volknit yarn -o "$d" -yarn_pattern rib1x1 -yarn_wales "$1" -yarn_courses "$2" -yarn_relax > "$d/yarn.log" 2>&1
  relax_s=$(sed -n 's/.*relaxed the yarns in .* (\([0-9.]*\) s)$/\1/p' "$d/yarn.log")
}
yls_row() { # ranks scene duration [options]: one table row from the summary line and yls.csv
  n=$1; scene=$2; T=$3; shift 3
  log="$d/yls.$scene.n$n.log"
  run $MPIEXEC -n "$n" bin/volknit yls -o "$d" -options_file "options/$scene.opts" -scene_duration "$T" -scene_output_interval 0.001 "$@" > "$log" 2>&1
  line=$(grep 'volknit yls: .* vertices, ' "$log")
  if [ -z "$line" ]; then echo "| $d | failed: see $log |"; return; fi
  nv=$(echo "$line" | sed -n 's/.*yls: \([0-9]*\) vertices.*/\1/p')
  nseg=$(sed -n 's/.*"segments": \([0-9]*\).*/\1/p' "$d/yls.json")
  steps=$(echo "$line" | sed -n 's/.* \([0-9]*\) steps of \([^ ]*\) s.*/\1/p')
  dt=$(echo "$line" | sed -n 's/.* steps of \([^ ]*\) s.*/\1/p')
  its=$(echo "$line" | sed -n 's/.*Newton its \([0-9.]*\)\/step (max \([0-9]*\)).*/\1 (max \2)/p')
  dmin=$(echo "$line" | sed -n 's/.*min distance \([0-9.]*\) x 2r.*/\1/p')
  wall=$(echo "$line" | sed -n 's/.*frames (\([0-9.]*\) s, .*/\1/p')
  persec=$(echo "$line" | sed -n 's/.*s, \([0-9.e+]*\) s per simulated second.*/\1/p')
  pairs=$(awk -F, 'NR > 2 { s += $9; if ($9 > m) m = $9; k++ } END { if (k) printf "%.0f (max %d)", s / k, m }' "$d/yls.csv")
  printf '| rib1x1 %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %.2f | %s | %s |\n' "$dims" "$nv" "$((3 * nv + nseg))" "$scene${*:+ $*}" "$n" "$dt" "$steps" "$its" "$pairs" "$dmin" \
    "$(awk -v w="$wall" -v s="$steps" 'BEGIN { print w / s }')" "$persec" "$relax_s"
}
echo "| patch | vertices | DOFs (positions, twists) | scene | ranks | dt s | steps | Newton its/step | contact pairs/step | min dist / 2r | s/step | s per simulated s | relaxation s (2 ranks) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
dims="8x7";   yls_relaxed 8 7
yls_row 2 hang 0.1
yls_row 2 stretch 0.1
yls_row 2 drape 0.1
yls_row 2 twist 0.1
yls_row 2 stretch 0.1 -yls_predict 0
yls_row 1 stretch 0.05
yls_accuracy() { # label options...: a row of what dt and Newton tolerance cost in accuracy, 2K patch, stretch, 30 ms
  label=$1; shift
  a="$d/acc_$label"; mkdir -p "$a"; cp "$d/yarn.h5" "$a/"
  run $MPIEXEC -n 2 bin/volknit yls -o "$a" -options_file options/stretch.opts -scene_duration 0.03 -yls_quiet "$@" > "$a/log" 2>&1
  run bin/tests/tool_compare_yls "$d/acc_ref/yls.h5" "$a/yls.h5" > "$a/compare" 2>&1
  its=$(sed -n 's/.*"newton_its_mean": \([0-9.]*\).*/\1/p' "$a/yls.json")
  persec=$(sed -n 's/.*"wall_time_per_simulated_second": \([0-9.]*\).*/\1/p' "$a/yls.json")
  err=$(awk '$2 == "0.030000" { print $3 " / " $4 }' "$a/compare")
  printf '| %s | %s | %.1f | %.0f | %s |\n' "$label" "$*" "$its" "$persec" "${err:-failed: see $a}"
}
echo
echo "What the time step and the Newton tolerance cost in accuracy (8x7 patch, stretch, t = 30 ms, 2 ranks): vertex"
echo "distance to a reference run at dt 0.5 ms and -yls_ftol 1e-6, largest / root-mean-square over the vertices, in r."
echo
echo "| run | options | Newton its/step | s per simulated s | distance at 30 ms, max / rms (r) |"
echo "|---|---|---|---|---|"
mkdir -p "$d/acc_ref"; cp "$d/yarn.h5" "$d/acc_ref/"
run $MPIEXEC -n 2 bin/volknit yls -o "$d/acc_ref" -options_file options/stretch.opts -scene_duration 0.03 -scene_output_interval 0.001 -yls_dt 0.0005 -yls_ftol 1e-6 -yls_quiet > "$d/acc_ref/log" 2>&1
yls_accuracy default -scene_output_interval 0.001
yls_accuracy ftol -scene_output_interval 0.001 -yls_ftol 1e-2
yls_accuracy dt2ms -scene_output_interval 0.002 -yls_dt 0.002 -yls_snes_max_it 200
yls_accuracy dt5ms -scene_output_interval 0.005 -yls_dt 0.005 -yls_snes_max_it 200
echo
echo "| patch | vertices | DOFs (positions, twists) | scene | ranks | dt s | steps | Newton its/step | contact pairs/step | min dist / 2r | s/step | s per simulated s | relaxation s (2 ranks) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
dims="24x25"; yls_relaxed 24 25
yls_row 2 stretch 0.03
yls_row 2 stretch 0.03 -yls_predict 0
yls_row 2 hang 0.005
echo
echo "Rows produced by:"
cat "$out/commands"
echo
echo "Each run starts from the relaxed rest state (relaxation timed separately, last column) at rest; dt is the"
echo "simulator's default for the scene (1 ms, less only if a handle would move more than half the contact cap per"
echo "step).  Contact pairs: segment pairs closer than 2r, mean and max over the frames (one per step here).  The 22K"
echo "rows cover the first 5 steps, the last two 30.  Published yarn-level figures for comparison: HYLC's yarn-level reference,"
echo "0.13-0.56 s per step at dt 5e-6 to 2e-5 s for 65K-158K vertices (Sperl's thesis, Table 4.2; 0.13 s per step at"
echo "dt 2e-5 s is 6,500 s per simulated second); Leaf et al. 2018, 0.07 us per control point per explicit GPU step."

echo
echo "## Periodic relaxation of a pyp cell (issue 23: relaxation reaches the full radius on overlapping models and"
echo "## keeps a tiled patch flat)"
echo
: > "$out/commands"
# The stockinette tile of meshes/ at its own radius (1 mm, no overlap) and at larger radii, where it overlaps:
# tiled 10 x 8 and relaxed as a patch (volknit yarn -yarn_relax), against the cell relaxed periodically and tiled.
echo "| r mm | relaxation | contact radius reached | bow of the interior, mm | s |"
echo "|---|---|---|---|---|"
# the plastic relaxation with inexact steps, then the anchored stage (-yls_relax_anchor)
anchored="-yarn_relax -yls_relax_plastic -yls_relax_radius_end 1.06 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000 -yls_relax_anchor 1e3"
per_row() { # radius, mode (patch | patch, plastic | patch, plastic, inexact steps | patch, plastic, anchored | periodic)
  local dir="$out/pyp_$(echo "$2" | tr -c 'a-z\n' '_')_$1" opt="-yarn_relax" t0 t1 cr bow px=0.009 py=0.007 mm
  [ "$2" = periodic ] && opt="-yarn_relax_periodic"
  [ "$2" = "patch, plastic" ] && opt="-yarn_relax -yls_relax_plastic -yls_relax_radius_end 1.03 -yls_relax_stages 8"
  [ "$2" = "patch, plastic, inexact steps" ] && opt="-yarn_relax -yls_relax_plastic -yls_relax_radius_end 1.03 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000"
  [ "$2" = "patch, plastic, anchored" ] && opt="$anchored"
  rm -rf "$dir"
  mm=$(awk -v r="$1" 'BEGIN { printf "%g", 1000 * r }')
  t0=$(date +%s.%N)
  if run bin/volknit yarn -o "$dir" -yarn_pyp meshes/stockinette.pyp -yarn_tiles 10,8 -yarn_radius "$1" $opt > "$dir.log" 2>&1; then
    t1=$(date +%s.%N)
    cr=$(sed -n 's/.*"contact_radius_m": \([^,]*\),*/\1/p' "$dir/yarn.json")
    if [ -s "$dir/cell.pyp" ]; then read -r px py _ < <(sed -n '/^\*pattern/{n;p}' "$dir/cell.pyp"); fi
    bow=$(python3 tools/yarn_flatness.py "$dir" "$px" "$py" | sed -n 's/.*bow \([0-9.]*\) mm/\1/p')
    echo "| $mm | $2 | $(awk -v c="$cr" -v r="$1" 'BEGIN { printf "%.4f", c / r }') r | ${bow:--} | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }') |"
  else
    echo "| $mm | $2 | failed: $(grep -o 'error: .*' "$dir.log" | head -1 | cut -c8-100) | - | - |"
  fi
}
for r in 0.001 0.0012 0.0013; do
  per_row $r patch
  if [ $r != 0.001 ]; then per_row $r "patch, plastic"; per_row $r "patch, plastic, inexact steps"; per_row $r "patch, plastic, anchored"; fi
  per_row $r periodic
done
echo
echo "Knit charts (8 x 8 stitches, r = 1 mm, the generator's loops): the patch relaxation of -yarn_relax against the"
echo "chart's repeat relaxed periodically and tiled (glued at the edges as a knit).  Width: the patch's x extent."
echo
echo "| pattern | relaxation | contact radius reached | bow of the interior, mm | z extent, mm | width, mm | s |"
echo "|---|---|---|---|---|---|---|"
knit_row() { # pattern, mode (patch | periodic), chart columns, rows
  local dir="$out/knit_$2_$1" opt="-yarn_relax" t0 t1 cr bow ext px py lo hi
  [ "$2" = periodic ] && opt="-yarn_relax_periodic"
  rm -rf "$dir"
  px=$(awk -v c="$3" 'BEGIN { printf "%g", 0.009 * c }'); py=$(awk -v c="$4" 'BEGIN { printf "%g", 0.007 * c }')
  t0=$(date +%s.%N)
  if run bin/volknit yarn -o "$dir" -yarn_pattern "$1" -yarn_wales 8 -yarn_courses 8 $opt > "$dir.log" 2>&1; then
    t1=$(date +%s.%N)
    cr=$(sed -n 's/.*"contact_radius_m": \([^,]*\),*/\1/p' "$dir/yarn.json")
    if [ -s "$dir/cell.pyp" ]; then read -r px py _ < <(sed -n '/^\*pattern/{n;p}' "$dir/cell.pyp"); fi
    read -r bow ext < <(python3 tools/yarn_flatness.py "$dir" "$px" "$py" | sed -n 's/.*z extent \([0-9.]*\) mm;.*bow \([0-9.]*\) mm/\2 \1/p')
    read -r lo hi < <(bin/volknit yarn -yarn_h5 "$dir/yarn.h5" -yarn_view 2>/dev/null | sed -n 's/.*bounding box \[\([^,]*\), \([^]]*\)\].*/\1 \2/p')
    echo "| $1 | $2 | $(awk -v c="$cr" 'BEGIN { printf "%.4f", c / 0.001 }') r | ${bow:--} | ${ext:--} | $(awk -v a="$lo" -v b="$hi" 'BEGIN { printf "%.1f", 1000 * (b - a) }') | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }') |"
  else
    echo "| $1 | $2 | failed: $(grep -o 'error: .*' "$dir.log" | head -1 | cut -c8-100) | - | - | - | - |"
  fi
}
for pat in "stockinette 1 1" "rib1x1 2 1"; do set -- $pat; knit_row "$1" patch "$2" "$3"; knit_row "$1" periodic "$2" "$3"; done
echo
echo "A BCC model, not periodic (meshes/rib_4x4.bcc, its radius estimated at 1.06 mm), relaxed as a patch at its"
echo "radius and at larger ones, where its loops overlap: the elastic relaxation against the plastic one with"
echo "inexact steps, and that one followed by the anchored stage.  Extent: of all vertices (the model as given:"
echo "36.0 x 32.9 x 3.0 mm)."
echo
echo "| r mm | relaxation | contact radius reached | extent x, y, z, mm | s |"
echo "|---|---|---|---|---|"
bcc_row() { # radius, mode (patch | patch, plastic, inexact steps | patch, plastic, anchored)
  local dir="$out/bcc_$(echo "$2" | tr -c 'a-z\n' '_')_$1" opt="-yarn_relax" t0 t1 cr ext
  [ "$2" = "patch, plastic, inexact steps" ] && opt="-yarn_relax -yls_relax_plastic -yls_relax_radius_end 1.03 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000"
  [ "$2" = "patch, plastic, anchored" ] && opt="$anchored"
  rm -rf "$dir"
  t0=$(date +%s.%N)
  if run bin/volknit yarn -o "$dir" -yarn_bcc meshes/rib_4x4.bcc -yarn_radius "$1" $opt > "$dir.log" 2>&1; then
    t1=$(date +%s.%N)
    cr=$(sed -n 's/.*"contact_radius_m": \([^,]*\),*/\1/p' "$dir/yarn.json")
    ext=$(bin/volknit yarn -yarn_h5 "$dir/yarn.h5" -yarn_view 2>/dev/null | sed -n 's/.*bounding box \[\([^,]*\), \([^]]*\)\] x \[\([^,]*\), \([^]]*\)\] x \[\([^,]*\), \([^]]*\)\].*/\1 \2 \3 \4 \5 \6/p' | awk '{ printf "%.1f, %.1f, %.2f", 1000 * ($2 - $1), 1000 * ($4 - $3), 1000 * ($6 - $5) }')
    echo "| $(awk -v r="$1" 'BEGIN { printf "%g", 1000 * r }') | $2 | $(awk -v c="$cr" -v r="$1" 'BEGIN { printf "%.4f", c / r }') r | ${ext:--} | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }') |"
  else
    echo "| $1 | $2 | failed: $(grep -o 'error: .*' "$dir.log" | head -1 | cut -c8-100) | - | - |"
  fi
}
for r in 0.00106 0.0012 0.0013; do bcc_row $r patch; bcc_row $r "patch, plastic, inexact steps"; bcc_row $r "patch, plastic, anchored"; done
echo
# A published model (issue 23): Cem Yuksel's openwork trellis swatch (cemyuksel.com/research/yarnmodels; also in
# the public repository github.com/H5uan/YarnCloth, Assets/Model/binary/openwork_trellis_pattern.bcc), not in
# this repository: BENCH_BCC=/path/to/openwork_trellis_pattern.bcc.  Two windows of 40 x 40 mm (-yarn_crop):
# the middle and the cast-on edge, where the given yarns overlap most (down to 0.35 x 2r between parts of the
# yarn, 0.018 x 2r at the tail).
if [ -n "${BENCH_BCC:-}" ] && [ -r "$BENCH_BCC" ]; then
  echo "A published model, windows of Yuksel's openwork trellis ($BENCH_BCC, -yarn_scale 0.01, radius estimated"
  echo "from the whole model): the default elastic relaxation against options/relax_model.opts"
  echo
  echo "| window | relaxation | ranks | contact radius reached | extent x, y, z, mm | height change: RMS, largest, range of 4 x 4 cell means, r | s |"
  echo "|---|---|---|---|---|---|---|"
  : > "$out/commands"
  model_row() { # window label, crop box, label, ranks, options
    local win="$1" box="$2" label="$3" n="$4" dir t0 t1 cr r ext dz
    shift 4
    dir="$out/model_$(echo "$win $label $n" | tr -c 'a-z0-9\n' '_')"
    rm -rf "$dir"
    t0=$(date +%s.%N)
    if run $MPIEXEC -n "$n" bin/volknit yarn -o "$dir" -yarn_bcc "$BENCH_BCC" -yarn_scale 0.01 -yarn_crop "$box" "$@" > "$dir.log" 2>&1 < /dev/null; then
      t1=$(date +%s.%N)
      cr=$(sed -n 's/.*"contact_radius_m": \([^,]*\),*/\1/p' "$dir/yarn.json"); r=$(sed -n 's/.*"radius_m": \([^,]*\),*/\1/p' "$dir/yarn.json")
      ext=$(bin/volknit yarn -yarn_h5 "$dir/yarn.h5" -yarn_view 2>/dev/null < /dev/null | sed -n 's/.*bounding box \[\([^,]*\), \([^]]*\)\] x \[\([^,]*\), \([^]]*\)\] x \[\([^,]*\), \([^]]*\)\].*/\1 \2 \3 \4 \5 \6/p' | awk '{ printf "%.1f, %.1f, %.2f", 1000 * ($2 - $1), 1000 * ($4 - $3), 1000 * ($6 - $5) }')
      if [ -n "$cr" ]; then cr="$(awk -v c="$cr" -v r="$r" 'BEGIN { printf "%.4f", c / r }') r"; else cr="(not relaxed)"; fi
      dz=$(bin/tests/tool_yarn_heights "$out/model_$(echo "$win" | tr -c 'a-z0-9\n' '_')_as_given_1/yarn.h5" "$dir/yarn.h5" -r "$r" -cells 4,4 2> /dev/null \
           | sed -n 's/height change: RMS \([^ ]*\) r, largest \([^ ]*\) r; mean over 4 x 4 cells from \([^ ]*\) r to \([^ ]*\) r/\1, \2, \3 .. \4/p')
      echo "| $win | $label | $n | $cr | ${ext:--} | ${dz:--} | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }') |"
    else
      echo "| $win | $label | $n | failed: $(grep -o 'error: .*' "$dir.log" | head -1 | cut -c8-140) | - | - | - |"
    fi
  }
  for w in "middle -0.02,0.02,-0.02,0.02" "cast-on-edge -0.02,0.02,-0.075,-0.035"; do
    set -- $w
    model_row "$1" "$2" "as given" 1
    model_row "$1" "$2" "elastic (default)" 1 -yarn_relax
    model_row "$1" "$2" "relax_model.opts" 1 -yarn_relax -options_file options/relax_model.opts
    model_row "$1" "$2" "relax_model.opts" 2 -yarn_relax -options_file options/relax_model.opts
    model_row "$1" "$2" "relax_model.opts in parallel (-yls_relax_serial 0)" 2 -yarn_relax -options_file options/relax_model.opts -yls_relax_serial 0
    model_row "$1" "$2" "relax_model.opts, plastic contact at -yls_kc (-yls_relax_plastic_kc 0)" 1 -yarn_relax -options_file options/relax_model.opts -yls_relax_plastic_kc 0
    model_row "$1" "$2" "relax_model.opts, radius end 1.1" 1 -yarn_relax -options_file options/relax_model.opts -yls_relax_radius_end 1.1
    model_row "$1" "$2" "relax_model.opts, plastic stages only (-yls_relax_anchor 0)" 1 -yarn_relax -options_file options/relax_model.opts -yls_relax_anchor 0
    model_row "$1" "$2" "relax_model.opts, plastic stages in a band of 2 r (-yls_relax_anchor 0 -yls_relax_flat 2)" 1 -yarn_relax -options_file options/relax_model.opts -yls_relax_anchor 0 -yls_relax_flat 2
    model_row "$1" "$2" "relax_model.opts, plastic stages in a band of 2 r (-yls_relax_anchor 0 -yls_relax_flat 2)" 2 -yarn_relax -options_file options/relax_model.opts -yls_relax_anchor 0 -yls_relax_flat 2
    model_row "$1" "$2" "relax_model.opts with a band of 2 r (-yls_relax_flat 2)" 1 -yarn_relax -options_file options/relax_model.opts -yls_relax_flat 2
  done
  echo
  echo "Rows produced by:"
  cat "$out/commands"
  # one verdict on two relaxed yarns: message if the same, message: h5diff's last line if not; h5diff options last
  same_yarn() {
    local same="$1" differ="$2" a="$3" b="$4"
    shift 4
    if h5same "$@" "$a" "$b" /yarn/x; then echo "$same"; else echo "$differ: $h5same_said"; fi
  }
  for w in middle cast_on_edge; do
    a="$out/model_${w}_relax_model_opts_1/yarn.h5"
    same_yarn "$w: relax_model.opts on 1 and 2 ranks gives the same relaxed yarn, bit for bit" "$w: relax_model.opts on 1 and 2 ranks differs" \
      "$a" "$out/model_${w}_relax_model_opts_2/yarn.h5"
    band="$out/model_${w}_relax_model_opts__plastic_stages_in_a_band_of_2_r___yls_relax_anchor_0__yls_relax_flat_2__"
    same_yarn "$w: the plastic stages in a band of 2 r on 1 and 2 ranks give the same relaxed yarn, bit for bit" "$w: the plastic stages in a band of 2 r on 1 and 2 ranks differ" \
      "${band}1/yarn.h5" "${band}2/yarn.h5"
    same_yarn "$w: relaxed in parallel on 2 ranks, the same yarn as on 1 to 1e-6 m" "$w: relaxed in parallel on 2 ranks, it differs from 1 rank by more than 1e-6 m" \
      "$a" "$out/model_${w}_relax_model_opts_in_parallel___yls_relax_serial_0__2/yarn.h5" -d 1e-6
  done
else
  echo "(A published model's windows: skipped, BENCH_BCC does not name a readable openwork_trellis_pattern.bcc.)"
fi
echo
echo "Rows produced by:"
cat "$out/commands"
echo
echo "One rank.  'contact radius reached' is the one the relaxed rest state honours (yarn.json).  The bow is the"
echo "range of the mean height over the patch's interior period cells (tools/yarn_flatness.py: two rings at the edges"
echo "left out; 0 for a periodic patch; needs python3 and h5dump of hdf5-tools).  The periodic rows include the"
echo "refinement of the cell to the segment length."
echo
echo "## The periodic state against the patch relaxed as a patch (issue 23: a periodic cell relaxed and tiled"
echo "## matches a relaxed tiled patch in its interior)"
echo
: > "$out/commands"
# A knit repeat relaxed periodically and tiled 8 x 8 (the reference), then relaxed again as a patch by the
# yarn-level relaxation with straight rest rods (the periodic relaxation's physics): its outer ring of repeats
# held by four handles, at contact radius r or at the one the periodic relaxation ended at (there also keeping
# the cell's rest lengths, -yarn_relax_periodic_rest, instead of the tiled ones); or free.
echo "| pattern | patch relaxation | proximal steps | interior against the periodic state: RMS / largest, r | z extent, mm | s |"
echo "|---|---|---|---|---|---|"
ring="-scene_handles 4 -scene_handle0_box -1,-1,-1,-0.375,1,1 -scene_handle1_box 0.375,-1,-1,1,1,1 -scene_handle2_box -1,-1,-1,1,-0.375,1 -scene_handle3_box -1,0.375,-1,1,1,1"
patch_row() { # pattern, label, options
  local pat="$1" label="$2" dir="$out/repatch_$1_$(echo "$2" | tr -c 'a-z0-9\n' '_')" t0 t1 steps line a shared=()
  shift 2
  rm -rf "$dir" "$dir.ref"
  # the reference: the tiled periodic state under the same periodic options (the periodic relaxation reads
  # the -yls_relax_stages and -yls_relax_radius_start of the patch relaxation too)
  for ((a = 1; a <= $#; a++)); do
    case "${!a}" in -yls_relax_stages|-yls_relax_radius_start) shared+=("${!a}"); a=$((a + 1)); shared+=("${!a}");; esac
  done
  run bin/volknit yarn -o "$dir.ref" -yarn_pattern "$pat" -yarn_wales 8 -yarn_courses 8 -yarn_relax_periodic "${shared[@]}" > "$dir.ref.log" 2>&1
  t0=$(date +%s.%N)
  if run bin/volknit yarn -o "$dir" -yarn_pattern "$pat" -yarn_wales 8 -yarn_courses 8 -yarn_relax_periodic -yarn_relax -yls_relax_straight "$@" > "$dir.log" 2>&1 \
     && t1=$(date +%s.%N) && line=$(python3 tools/yarn_compare.py "$dir.ref" "$dir" 2>&1); then
    steps=$(sed -n 's/.*relaxed the yarns in \([0-9]*\) proximal steps.*/\1/p' "$dir.log")
    echo "| $pat | $label | $steps | $(echo "$line" | sed -n 's/.*RMS \([0-9.]*\) r, largest \([0-9.]*\) r;.*/\1 \/ \2/p') | $(echo "$line" | sed -n 's/.*and \([0-9.]*\) mm.*/\1/p') | $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') |"
  else
    echo "| $pat | $label | failed: $( (grep -o 'error: .*' "$dir.log"; echo "$line") | head -1 | cut -c1-100) | - | - | - |"
  fi
}
for pat in stockinette rib1x1; do
  rm -rf "$out/repatch_${pat}_radius"
  run bin/volknit yarn -o "$out/repatch_${pat}_radius" -yarn_pattern "$pat" -yarn_wales 8 -yarn_courses 8 -yarn_relax_periodic -yls_relax_stages 1 -yls_relax_radius_start 1 > "$out/repatch_${pat}_radius.log" 2>&1
  f=$(sed -n "s/.*relaxed the knit chart's repeat periodically:.* to \([0-9.]*\) r).*/\1/p" "$out/repatch_${pat}_radius.log")
  patch_row "$pat" "ring held, at r" -yls_relax_handles $ring -yls_relax_stages 1 -yls_relax_radius_start 1
  patch_row "$pat" "ring held, at $f r" -yls_relax_handles $ring -yls_relax_stages 1 -yls_relax_radius_start 1 -yls_relax_radius_end "$f"
  patch_row "$pat" "ring held, at $f r, the cell's rest state kept" -yarn_relax_periodic_rest -yls_relax_handles $ring -yls_relax_stages 1 -yls_relax_radius_start 1 -yls_relax_radius_end "$f"
  patch_row "$pat" "free, inexact steps" -yls_relax_newton_its 15 -yls_relax_tau_growth 1e12 -yls_relax_max_steps 100000
done
echo
echo "Rows produced by (each after its reference, the tiled periodic state under the same options):"
cat "$out/commands"
echo
echo "One rank.  Interior: the vertices more than a quarter of the patch from its edges, after the rigid motion"
echo "that fits them best (tools/yarn_compare.py).  The yarn model's rest lengths are the tiled patch's own, so"
echo "the periodic state's yarn tension is released when it is relaxed again (docs/BENCHMARKS.md)."
