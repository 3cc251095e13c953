#!/bin/bash
# tests/run_tests.sh: everything `make check` runs.
#  1. every tests/test_*.c program, with each rank count its header names
#     ("ranks: 1 2"); their TAP lines "ok"/"not ok" are counted, and a
#     program that crashes or exits non-zero counts as one more failure;
#  2. every broken input of tests/bad/cases, with 1 and 2 ranks: it must
#     fail with a non-zero status, no crash and no hang, print the expected
#     message in one line (no PETSc traceback), and leave no file in its
#     output directory;
#  3. `volknit mesh` on the demo scene with 1 and 2 ranks, compared by
#     tests/tool_compare_mesh (same mesh, masses, embedding, partition);
#  4. the example programs;
#  5. `volknit fit` with 1 and 2 ranks (both losses), stopped and restarted, killed and
#     restarted, and with broken checkpoints (tests/tool_compare_material);
#  6. `volknit run` sweeps: the report over the points, the best uniform
#     material, 1 and 2 ranks, and the cached yarn-level reference.
# Ends with the line "N passed, M failed"; exit status 1 if M > 0.
set -u
cd "$(dirname "$0")/.."
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIEXEC=${MPIEXEC:-mpiexec}
TIMEOUT=${TIMEOUT:-600}
out=tests/out
rm -rf "$out"
mkdir -p "$out"
passed=0
failed=0
. tests/h5same.sh

ok()     { passed=$((passed + 1)); }
not_ok() { failed=$((failed + 1)); echo "not ok - $*"; }

# 1. test programs
for src in tests/test_*.c; do
  name=$(basename "$src" .c)
  ranks=$(sed -n 's/^ \* ranks: *\([0-9][0-9 ]*[0-9]\|[0-9]\) *\(\*\/\)\{0,1\}$/\1/p' "$src" | head -n 1)
  if [ -z "$ranks" ]; then
    if grep -q 'ranks:' "$src"; then not_ok "$name: unreadable ' * ranks:' line"; fi
    ranks=1
  fi
  for n in $ranks; do
    log="$out/$name.n$n.log"
    timeout "$TIMEOUT" $MPIEXEC -n "$n" "bin/tests/$name" -o "$out/$name.n$n" > "$log" 2>&1
    rc=$?
    p=$(grep -c '^ok ' "$log")
    f=$(grep -c '^not ok ' "$log")
    passed=$((passed + p))
    failed=$((failed + f))
    grep -E '^(not ok|# \[rank)' "$log" | sed "s|^|$name -n $n: |"
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then not_ok "$name -n $n exited with status $rc (see $log)"; fi
    printf '%-22s -n %s: %4d passed, %d failed\n' "$name" "$n" "$p" "$f"
  done
done

# 2. broken inputs
k=0
bad_passed=0
while IFS='|' read -r expect args; do
  expect=$(echo "$expect" | sed 's/ *$//')
  case "$expect" in ''|'#'*) continue ;; esac
  k=$((k + 1))
  for n in 1 2; do
    dir="$out/bad/$k.n$n"
    log="$out/bad/$k.n$n.log"
    mkdir -p "$out/bad"
    # shellcheck disable=SC2086
    set -- $args   # the command, then its options; our -o comes first so a case may override it
    cmd=$1
    shift
    # one rank runs as an MPI singleton: mpiexec itself waits 2 s after a failed job
    if [ "$n" -eq 1 ]; then launch=""; else launch="$MPIEXEC -n $n"; fi
    timeout 120 $launch bin/volknit "$cmd" -o "$dir" "$@" > "$log" 2>&1 </dev/null
    rc=$?
    why=""
    if [ "$rc" -eq 0 ]; then why="exit status 0"
    elif [ "$rc" -eq 124 ]; then why="hung (timeout)"
    elif grep -qiE 'segmentation|caught signal|SIGSEGV|SIGBUS|SIGFPE|core dumped|AddressSanitizer' "$log"; then why="crashed"
    elif ! grep -qF -- "$expect" "$log"; then why="message '$expect' not printed"
    elif grep -q 'PETSC ERROR' "$log"; then why="a PETSc traceback, where bad input gets one line"
    elif [ -d "$dir" ] && [ -n "$(find "$dir" -type f)" ]; then why="left files in $dir: $(find "$dir" -type f | tr '\n' ' ')"
    fi
    if [ -z "$why" ]; then ok; bad_passed=$((bad_passed + 1)); else not_ok "bad input $k (-n $n): volknit $args: $why (see $log)"; fi
  done
done < tests/bad/cases
printf '%-22s       : %4d passed, %d failed\n' "broken inputs" "$bad_passed" "$((2 * k - bad_passed))"

# a misspelled command-line option is an error naming the closest option; -options_unused_ok makes it a warning
for n in 1 2; do
  log="$out/unused.n$n.log"
  if [ "$n" -eq 1 ]; then launch=""; else launch="$MPIEXEC -n $n"; fi
  if ! timeout 120 $launch bin/volknit yarn -o "$out/unused.n$n" -yarn_pattern rib1x1 -yarn_wales 2 -yarn_courses 2 -yarn_walse 3 > "$log" 2>&1 \
     && grep -q 'option -yarn_walse 3 was given but nothing read it (did you mean -yarn_wales?)' "$log" && ! grep -q 'PETSC ERROR' "$log"; then ok
  else not_ok "volknit yarn -yarn_walse 3 (-n $n): expected a non-zero exit naming -yarn_wales, without a PETSc traceback (see $log)"; fi
  if timeout 120 $launch bin/volknit yarn -o "$out/unused.n$n" -yarn_pattern rib1x1 -yarn_wales 2 -yarn_courses 2 -yarn_walse 3 -options_unused_ok > "$log" 2>&1 \
     && grep -q 'warning: option -yarn_walse 3 was given but nothing read it' "$log"; then ok
  else not_ok "volknit yarn -yarn_walse 3 -options_unused_ok (-n $n): expected exit 0 and a warning (see $log)"; fi
done

# a BCC model in centimetres is accepted with a warning that names the scale
log="$out/centimetres.log"
if timeout 120 bin/volknit yarn -o "$out/centimetres" -yarn_bcc tests/bad/centimetres.bcc > "$log" 2>&1 \
   && grep -q 'WARNING: .* where knit yarns are 0.1 - 5 mm; if the file is not in metres, -yarn_scale 0.01 makes it' "$log"; then ok
else not_ok "volknit yarn -yarn_bcc tests/bad/centimetres.bcc: expected exit 0 and a warning naming -yarn_scale 0.01 (see $log)"; fi

# -error_traceback keeps PETSc's traceback for an input error
log="$out/traceback.log"
if ! timeout 120 bin/volknit yarn -o "$out/traceback" -yarn_wales 0 -error_traceback > "$log" 2>&1 \
   && grep -q 'PETSC ERROR: #1 ' "$log" && grep -q -- '-yarn_wales 0 is out of range' "$log"; then ok
else not_ok "volknit yarn -yarn_wales 0 -error_traceback: expected a non-zero exit with the PETSc traceback (see $log)"; fi

# a pyp cell relaxed periodically (issue 23): the patch tiled from it keeps
# the full contact radius as it is (no second relaxation), the relaxed cell
# is written, and 1 and 2 ranks relax the same cell
for n in 1 2; do
  log="$out/periodic.n$n.log"
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$out/periodic.n$n" -yarn_pyp meshes/stockinette.pyp -yarn_relax_periodic -yarn_tiles 4,3 > "$log" 2>&1 \
     && [ -s "$out/periodic.n$n/cell.pyp" ] && grep -q '"relaxed": true' "$out/periodic.n$n/yarn.json" \
     && grep -q 'the tiled patch is the relaxed rest state (not relaxed again): contact radius 1.0000 r' "$log"; then ok
  else not_ok "volknit yarn -yarn_relax_periodic (-n $n): expected cell.pyp, a relaxed yarn at contact radius 1.0000 r (see $log)"; fi
done
if cmp -s "$out/periodic.n1/cell.pyp" "$out/periodic.n2/cell.pyp"; then ok
else not_ok "the periodically relaxed cell differs between 1 and 2 ranks ($out/periodic.n1/cell.pyp, $out/periodic.n2/cell.pyp)"; fi
# and a knit chart's repeat: rib1x1 tiled 4 x 3 into 8 wales x 3 courses
for n in 1 2; do
  log="$out/periodic_knit.n$n.log"
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$out/periodic_knit.n$n" -yarn_pattern rib1x1 -yarn_wales 8 -yarn_courses 3 -yarn_relax_periodic > "$log" 2>&1 \
     && [ -s "$out/periodic_knit.n$n/cell.pyp" ] && grep -q '"relaxed": true' "$out/periodic_knit.n$n/yarn.json" \
     && grep -q "relaxed the knit chart's repeat periodically" "$log" \
     && grep -q 'the tiled patch is the relaxed rest state (not relaxed again): contact radius 0.9999 r' "$log" \
     && grep -q 'relaxed periodically: 3 curves, 900 vertices' "$log"; then ok
  else not_ok "volknit yarn -yarn_pattern rib1x1 -yarn_relax_periodic (-n $n): expected cell.pyp and 3 courses of 900 vertices relaxed at contact radius 0.9999 r (see $log)"; fi
done
if cmp -s "$out/periodic_knit.n1/cell.pyp" "$out/periodic_knit.n2/cell.pyp"; then ok
else not_ok "the periodically relaxed knit repeat differs between 1 and 2 ranks ($out/periodic_knit.n1/cell.pyp, $out/periodic_knit.n2/cell.pyp)"; fi
# the tiled repeat relaxed again as a patch (-yarn_relax with
# -yarn_relax_periodic): straight rods, the outer ring of repeats held by
# the scene's handles; 1 and 2 ranks relax the same yarn
for n in 1 2; do
  log="$out/periodic_patch.n$n.log"
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$out/periodic_patch.n$n" -yarn_pattern stockinette -yarn_wales 4 -yarn_courses 4 -yarn_relax_periodic -yarn_relax \
       -yls_relax_straight -yls_relax_handles -scene_handles 4 -scene_handle0_box -1,-1,-1,-0.25,1,1 -scene_handle1_box 0.25,-1,-1,1,1,1 \
       -scene_handle2_box -1,-1,-1,1,-0.25,1 -scene_handle3_box -1,0.25,-1,1,1,1 > "$log" 2>&1 \
     && grep -q 'the tiled patch is relaxed again as a patch' "$log" && grep -q 'volknit yls: relaxed the yarns in' "$log" \
     && grep -q '"relaxed": true' "$out/periodic_patch.n$n/yarn.json"; then ok
  else not_ok "volknit yarn -yarn_relax_periodic -yarn_relax -yls_relax_handles (-n $n): expected the tiled patch relaxed again with its ring held (see $log)"; fi
done
if h5same -d 1e-6 "$out/periodic_patch.n1/yarn.h5" "$out/periodic_patch.n2/yarn.h5" /yarn/x; then ok
else not_ok "the tiled patch relaxed as a patch differs between 1 and 2 ranks by more than 1e-3 r ($out/periodic_patch.n1/yarn.h5, $out/periodic_patch.n2/yarn.h5)"; fi

# the tiled repeat keeping the cell's rest state (-yarn_relax_periodic_rest):
# held at its outer ring of repeats, the yarn-level run finds it static
# (the periodic equilibrium, tension and all); left free, it moves at once
# (its rest state is not the tiled geometry); 1 and 2 ranks agree
ring="-scene_handles 4 -scene_handle0_box -1,-1,-1,-0.25,1,1 -scene_handle1_box 0.25,-1,-1,1,1,1 -scene_handle2_box -1,-1,-1,1,-0.25,1 -scene_handle3_box -1,0.25,-1,1,1,1"
for n in 1 2; do
  d="$out/periodic_rest.n$n"
  log="$d.log"
  # shellcheck disable=SC2086
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$d" -yarn_pattern stockinette -yarn_wales 4 -yarn_courses 4 -yarn_relax_periodic -yarn_relax_periodic_rest > "$log" 2>&1 \
     && grep -q "it keeps the cell's rest state" "$log" && grep -q '"rest_state": "cell' "$d/yarn.json" \
     && timeout 300 $MPIEXEC -n "$n" bin/volknit yls -o "$d/held" -yarn_h5 "$d/yarn.h5" -scene_gravity 0,0,0 -scene_duration 0.005 -scene_output_interval 0.005 $ring >> "$log" 2>&1 \
     && h5same -d 1e-9 "$d/held/yls.h5" "$d/held/yls.h5" /frames/000000/x /frames/000001/x \
     && timeout 300 $MPIEXEC -n "$n" bin/volknit yls -o "$d/free" -yarn_h5 "$d/yarn.h5" -scene_gravity 0,0,0 -scene_duration 0.002 -scene_output_interval 0.002 >> "$log" 2>&1 \
     && { h5diff -d 1e-6 "$d/free/yls.h5" "$d/free/yls.h5" /frames/000000/x /frames/000001/x > /dev/null 2>&1; [ $? -eq 1 ]; }; then ok
  else not_ok "volknit yarn -yarn_relax_periodic -yarn_relax_periodic_rest, then yls (-n $n): expected the ring-held patch static to 1e-6 r over 5 steps and the free one moving more than 1e-3 r in 2 (see $log)"; fi
done
if h5same -d 1e-12 "$out/periodic_rest.n1/yarn.h5" "$out/periodic_rest.n2/yarn.h5" /yarn/rest_length; then ok
else not_ok "the rest lengths of the patch keeping its cell's rest state differ between 1 and 2 ranks ($out/periodic_rest.n1/yarn.h5, $out/periodic_rest.n2/yarn.h5)"; fi
# the same through a pyp cell at twice its file's size (-yarn_scale 2: the
# cell relaxed at its size in metres, its rest lengths scaled with it)
d="$out/periodic_rest_pyp"
log="$d.log"
# shellcheck disable=SC2086
if timeout 300 bin/volknit yarn -o "$d" -yarn_pyp meshes/stockinette.pyp -yarn_scale 2 -yarn_tiles 4,4 -yarn_relax_periodic -yarn_relax_periodic_rest > "$log" 2>&1 < /dev/null \
   && grep -q "it keeps the cell's rest state" "$log" \
   && timeout 300 bin/volknit yls -o "$d/held" -yarn_h5 "$d/yarn.h5" -scene_gravity 0,0,0 -scene_duration 0.005 -scene_output_interval 0.005 $ring >> "$log" 2>&1 < /dev/null \
   && h5same -d 1e-9 "$d/held/yls.h5" "$d/held/yls.h5" /frames/000000/x /frames/000001/x; then ok
else not_ok "volknit yarn -yarn_pyp meshes/stockinette.pyp -yarn_scale 2 -yarn_relax_periodic -yarn_relax_periodic_rest, then yls: expected the ring-held patch static to 5e-7 r over 5 steps (see $log)"; fi

# a pyp patch whose loops overlap at its radius (the stockinette tile of
# meshes/ at r = 1.2 mm, made for 1 mm) relaxed as a patch: the elastic
# relaxation creeps below r until its step limit (an error, measured at
# 0.95 r), the plastic one (-yls_relax_plastic) reaches the full radius;
# 1 and 2 ranks agree
overlap="-yarn_pyp meshes/stockinette.pyp -yarn_tiles 4,3 -yarn_radius 0.0012 -yarn_relax"
log="$out/overlap_elastic.log"
# shellcheck disable=SC2086
if ! timeout 300 bin/volknit yarn -o "$out/overlap_elastic" $overlap > "$log" 2>&1 < /dev/null \
   && grep -q 'did not reach a static state in 50 proximal steps' "$log"; then ok
else not_ok "volknit yarn $overlap: expected the elastic relaxation to stop below r with an error, as measured (see $log)"; fi
for n in 1 2; do
  log="$out/overlap_plastic.n$n.log"
  # shellcheck disable=SC2086
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$out/overlap_plastic.n$n" $overlap -yls_relax_plastic -yls_relax_radius_end 1.03 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000 > "$log" 2>&1 \
     && grep -q 'contact radius 0.0012 m (r = 0.0012 m)' "$log" && grep -q '"relaxed": true' "$out/overlap_plastic.n$n/yarn.json"; then ok
  else not_ok "volknit yarn $overlap -yls_relax_plastic (-n $n): expected the full contact radius 0.0012 m (see $log)"; fi
done
if h5same -d 1e-6 "$out/overlap_plastic.n1/yarn.h5" "$out/overlap_plastic.n2/yarn.h5" /yarn/x; then ok
else not_ok "the plastic relaxation differs between 1 and 2 ranks by more than 1e-3 r ($out/overlap_plastic.n1/yarn.h5, $out/overlap_plastic.n2/yarn.h5)"; fi
# the plastic flow bows that patch (z extent 7.6 mm measured at
# -yls_relax_radius_end 1.06); the anchored stage (-yls_relax_anchor) keeps
# it near its given shape (3.7 mm) at the full radius, the same on 1 and 2
# ranks
z_extent() { timeout 60 bin/volknit yarn -o "$1/view" -yarn_h5 "$1/yarn.h5" -yarn_view 2>/dev/null | sed -n 's/.*x \[\([^,]*\), \([^]]*\)\] m$/\1 \2/p' | awk '{ printf "%.6f", 1000 * ($2 - $1) }'; }
# shellcheck disable=SC2086
if timeout 300 bin/volknit yarn -o "$out/overlap_plain106" $overlap -yls_relax_plastic -yls_relax_radius_end 1.06 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000 > "$out/overlap_plain106.log" 2>&1 < /dev/null \
   && zplain=$(z_extent "$out/overlap_plain106") && [ -n "$zplain" ]; then ok
else zplain=; not_ok "volknit yarn $overlap -yls_relax_plastic -yls_relax_radius_end 1.06: the plain plastic relaxation failed (see $out/overlap_plain106.log)"; fi
for n in 1 2; do
  d="$out/overlap_anchor.n$n"; log="$d.log"; z=
  # shellcheck disable=SC2086
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$d" $overlap -yls_relax_plastic -yls_relax_radius_end 1.06 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000 -yls_relax_anchor 1e3 > "$log" 2>&1 \
     && grep -q 'then the anchored stage), contact radius 0.0012 m (r = 0.0012 m)' "$log" \
     && z=$(z_extent "$d") && awk -v z="$z" -v p="$zplain" 'BEGIN { exit !(z > 0 && p > 0 && z < 0.75 * p) }'; then ok
  else not_ok "volknit yarn $overlap -yls_relax_plastic -yls_relax_anchor 1e3 (-n $n): expected the full contact radius and a z extent under 0.75 x the plain plastic one's ${zplain:-?} mm, got ${z:-?} mm (see $log)"; fi
done
if h5same -d 1e-6 "$out/overlap_anchor.n1/yarn.h5" "$out/overlap_anchor.n2/yarn.h5" /yarn/x; then ok
else not_ok "the anchored relaxation differs between 1 and 2 ranks by more than 1e-3 r ($out/overlap_anchor.n1/yarn.h5, $out/overlap_anchor.n2/yarn.h5)"; fi
# the band of -yls_relax_flat 1 keeps every vertex within 1 r of its given
# height at the full radius (the plain plastic flow moves them by up to 2.5
# r, measured), the same on 1 and 2 ranks
max_dz() { bin/tests/tool_yarn_heights "$1/yarn.h5" "$2/yarn.h5" -r 0.0012 2> /dev/null | sed -n 's/.*largest \([0-9.]*\) r.*/\1/p'; }
timeout 60 bin/volknit yarn -o "$out/overlap_given" ${overlap% -yarn_relax} > "$out/overlap_given.log" 2>&1 < /dev/null
dzplain=$(max_dz "$out/overlap_given" "$out/overlap_plain106")
for n in 1 2; do
  d="$out/overlap_flat.n$n"; dz=
  # shellcheck disable=SC2086
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$d" $overlap -yls_relax_plastic -yls_relax_radius_end 1.06 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000 -yls_relax_flat 1 > "$d.log" 2>&1 \
     && grep -q 'contact radius 0.0012 m (r = 0.0012 m)' "$d.log" \
     && dz=$(max_dz "$out/overlap_given" "$d") && awk -v z="$dz" -v p="$dzplain" 'BEGIN { exit !(z != "" && z <= 1.02 && p > 1.5) }'; then ok
  else not_ok "volknit yarn $overlap -yls_relax_plastic -yls_relax_flat 1 (-n $n): expected the full contact radius and every vertex within 1.02 r of its given height (the plain plastic flow: ${dzplain:-?} r, over 1.5), got ${dz:-?} r (see $d.log)"; fi
done
if h5same -d 1e-6 "$out/overlap_flat.n1/yarn.h5" "$out/overlap_flat.n2/yarn.h5" /yarn/x; then ok
else not_ok "the relaxation with -yls_relax_flat differs between 1 and 2 ranks by more than 1e-3 r ($out/overlap_flat.n1/yarn.h5, $out/overlap_flat.n2/yarn.h5)"; fi
# and a BCC model that is not periodic, the rib of meshes/ at r = 1.2 mm:
# the elastic relaxation ends under r (measured 0.9776 r), the plastic one at r
log="$out/bcc_plastic.log"
if timeout 300 bin/volknit yarn -o "$out/bcc_elastic" -yarn_bcc meshes/rib_4x4.bcc -yarn_radius 0.0012 -yarn_relax > "$log" 2>&1 < /dev/null \
   && ! grep -q 'contact radius 0.0012 m (r = 0.0012 m)' "$log" \
   && timeout 300 bin/volknit yarn -o "$out/bcc_plastic" -yarn_bcc meshes/rib_4x4.bcc -yarn_radius 0.0012 -yarn_relax -yls_relax_plastic -yls_relax_radius_end 1.03 -yls_relax_stages 8 -yls_relax_newton_its 5 -yls_relax_max_steps 1000 >> "$log" 2>&1 < /dev/null \
   && grep -q 'contact radius 0.0012 m (r = 0.0012 m)' "$log"; then ok
else not_ok "volknit yarn -yarn_bcc meshes/rib_4x4.bcc -yarn_radius 0.0012 -yarn_relax: expected the elastic relaxation under r and the plastic one at r (see $log)"; fi
# a window of a BCC model (-yarn_crop): fewer vertices, the radius still
# estimated from the whole model (1.05859 mm), and at r = 1.2 mm relaxed by
# options/relax_model.opts to the full radius, the same on 1 and 2 ranks
# bit for bit (the recipe relaxes on one rank, -yls_relax_serial)
log="$out/bcc_crop.log"
if timeout 120 bin/volknit yarn -o "$out/bcc_crop" -yarn_bcc meshes/rib_4x4.bcc -yarn_crop 0.006,0.030,-0.01,0.03 > "$log" 2>&1 < /dev/null \
   && grep -q 'cropped to \[0.006, 0.03\] x \[-0.01, 0.03\] m (8 pieces under 0.0105859 m dropped): 4 curves, 304 vertices, .* r = 0.00105859 m' "$log"; then ok
else not_ok "volknit yarn -yarn_bcc meshes/rib_4x4.bcc -yarn_crop 0.006,0.030,-0.01,0.03: expected 4 curves, 304 vertices (552 uncropped) at the whole model's radius 1.05859 mm (see $log)"; fi
for n in 1 2; do
  d="$out/bcc_crop_relax.n$n"
  if timeout 300 $MPIEXEC -n "$n" bin/volknit yarn -o "$d" -yarn_bcc meshes/rib_4x4.bcc -yarn_radius 0.0012 -yarn_crop 0.006,0.030,-0.01,0.03 -yarn_relax -options_file options/relax_model.opts > "$d.log" 2>&1 \
     && grep -q 'then the anchored stage), contact radius 0.0012 m (r = 0.0012 m)' "$d.log"; then ok
  else not_ok "a cropped BCC window relaxed by options/relax_model.opts (-n $n): expected the full contact radius (see $d.log)"; fi
done
if h5same "$out/bcc_crop_relax.n1/yarn.h5" "$out/bcc_crop_relax.n2/yarn.h5" /yarn/x; then ok
else not_ok "the cropped window's relaxation by options/relax_model.opts differs between 1 and 2 ranks ($out/bcc_crop_relax.n1/yarn.h5, $out/bcc_crop_relax.n2/yarn.h5)"; fi

# 3. the mesh command with 1 and 2 ranks gives the same mesh
cmp_passed=$passed
cmp_failed=$failed
for d in 1 2; do
  for n in 1 2; do
    timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/volknit mesh -options_file options/demo.opts -dd_domains "$d" -o "$out/cmp.d$d.n$n" > "$out/cmp.d$d.n$n.log" 2>&1 \
      || not_ok "volknit mesh -dd_domains $d with $n ranks failed (see $out/cmp.d$d.n$n.log)"
  done
  log="$out/cmp.d$d.log"
  bin/tests/tool_compare_mesh "$out/cmp.d$d.n1/mesh.h5" "$out/cmp.d$d.n2/mesh.h5" > "$log" 2>&1
  rc=$?
  p=$(grep -c '^ok ' "$log"); f=$(grep -c '^not ok ' "$log")
  passed=$((passed + p)); failed=$((failed + f))
  grep '^not ok' "$log" | sed "s|^|mesh -dd_domains $d, 1 vs 2 ranks: |"
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then not_ok "tool_compare_mesh exited with status $rc (see $log)"; fi
done
# a 30 x 30 rib meshed to file, then simulated from the file (its lumping
# once left a node with mass -2.1e-37, which the reader refuses)
d30="$out/rib30"
if timeout "$TIMEOUT" bin/volknit mesh -yarn_pattern rib1x1 -yarn_wales 30 -yarn_courses 30 -o "$d30" > "$d30.mesh.log" 2>&1 \
   && timeout "$TIMEOUT" $MPIEXEC -n 2 bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.02 > "$d30.sim.log" 2>&1 \
   && [ -s "$d30/sim.h5" ]; then ok
else not_ok "30 x 30 rib: volknit mesh to file, then volknit sim -n 2 from it (see $d30.mesh.log, $d30.sim.log)"; fi
# a mesh of 1 domain simulated on 2 ranks: said, not silently all on rank 0
if timeout "$TIMEOUT" bin/volknit mesh -yarn_pattern rib1x1 -yarn_wales 2 -yarn_courses 2 -dd_domains 1 -o "$out/dd1" > "$out/dd1.log" 2>&1 \
   && timeout "$TIMEOUT" $MPIEXEC -n 2 bin/volknit sim -o "$out/dd1" -scene_duration 0.01 >> "$out/dd1.log" 2>&1 \
   && grep -q 'WARNING: the mesh has 1 domain for 2 ranks, so 1 rank holds no tets' "$out/dd1.log"; then ok
else not_ok "a 1-domain mesh on 2 ranks: expected the warning that rank 1 holds no tets (see $out/dd1.log)"; fi
# a duration that is no multiple of the step (1/150 s) or of the output
# interval (1/30 s): the frames fall on k x the interval and the last one
# on the duration (the last step is shortened)
if timeout "$TIMEOUT" $MPIEXEC -n 2 bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.05 > "$d30.t005.log" 2>&1; then
  times=$(sed -n 's/.*<Time Value="\([^"]*\)".*/\1/p' "$d30/sim.xdmf" | sort -g -u | tr '\n' ' ')
  if echo "$times" | awk '{ n = NF; ok = (n == 3 && $n == 0.05); for (k = 1; k < n; k++) { d = $k - (k - 1) / 30; if (d < -1e-12 || d > 1e-12) ok = 0 } exit !ok }'; then ok
  else not_ok "sim -scene_duration 0.05: frame times '$times', expected 0, 1/30 and 0.05 (see $d30.t005.log)"; fi
else not_ok "sim -scene_duration 0.05 failed (see $d30.t005.log)"; fi
# a material far too stiff for the tolerance (1e14 Pa): every step stops at
# the round-off floor, above -pd_ftol x f_scale; said so, counted in
# sim.json, status unconverged, an error with -sim_strict; a sane material
# has no such step
if timeout "$TIMEOUT" bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.02 -mat_gamma_s 1e14 -mat_gamma_v 1e14 > "$d30.roundoff.log" 2>&1 \
   && grep -q 'WARNING: 3 of 3 steps stopped at the round-off floor' "$d30.roundoff.log" && grep -q '"roundoff_limited_steps": 3,' "$d30/sim.json" \
   && grep -q '"status": "unconverged"' "$d30/sim.json" \
   && ! timeout "$TIMEOUT" bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.02 -mat_gamma_s 1e14 -mat_gamma_v 1e14 -sim_strict > "$d30.roundoff.strict.log" 2>&1 \
   && grep -q 'stopped at the round-off floor of |grad Phi| (-sim_strict)' "$d30.roundoff.strict.log" \
   && timeout "$TIMEOUT" bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.02 > "$d30.roundoff0.log" 2>&1 \
   && ! grep -q 'round-off floor' "$d30.roundoff0.log" && grep -q '"roundoff_limited_steps": 0,' "$d30/sim.json"; then ok
else not_ok "volknit sim at 1e14 Pa: expected the round-off warning, roundoff_limited_steps 3 and status unconverged in sim.json, an error with -sim_strict, none at the default material (see $d30.roundoff.log, $d30.roundoff.strict.log, $d30.roundoff0.log)"; fi
# a step stopped at -pd_max_it: warned about, status "unconverged"; with -sim_strict an error
if timeout "$TIMEOUT" bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.02 -pd_max_it 1 > "$d30.unconv.log" 2>&1 \
   && grep -q 'did not converge' "$d30.unconv.log" && grep -q '"status": "unconverged"' "$d30/sim.json"; then ok
else not_ok "volknit sim -pd_max_it 1: expected a warning and status unconverged in sim.json (see $d30.unconv.log)"; fi
timeout "$TIMEOUT" bin/volknit sim -o "$d30" -options_file options/hang.opts -scene_duration 0.02 -pd_max_it 1 -sim_strict > "$d30.strict.log" 2>&1
rc=$?
if [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] && grep -q 'did not converge (MAX_IT, -sim_strict)' "$d30.strict.log"; then ok
else not_ok "volknit sim -pd_max_it 1 -sim_strict: expected a non-zero exit naming the step (status $rc, see $d30.strict.log)"; fi
# a material with next to no shear stiffness (g_s 1e-8, g_v 1e5 Pa, the
# 4 x 4 rib's hang, one rank): where projected Newton's line search finds
# no decrease, the PD step goes on (line_search_restarts), and every step
# converges; stopping there instead left 6 of the 30 steps unconverged
dv="$out/volume_dominated"
if timeout "$TIMEOUT" bin/volknit mesh -yarn_pattern rib1x1 -yarn_wales 4 -yarn_courses 4 -o "$dv" > "$dv.log" 2>&1 \
   && timeout "$TIMEOUT" bin/volknit sim -o "$dv" -options_file options/hang.opts -scene_duration 0.2 -mat_gamma_s 1e-8 -mat_gamma_v 1e5 >> "$dv.log" 2>&1 \
   && grep -q '"status": "completed"' "$dv/sim.json" && grep -q '"steps_stalled": 0,' "$dv/sim.json" \
   && [ "$(sed -n 's/.*"line_search_restarts": \([0-9]*\).*/\1/p' "$dv/sim.json")" -gt 0 ]; then ok
else not_ok "volknit sim, g_s 1e-8 and g_v 1e5 Pa: expected every step converged, with PD steps taken for rejected Newton directions (see $dv.log, $dv/sim.json)"; fi
# the same for the yarn-level Newton: one iteration and no halving per step
dy="$out/yls_unconverged"
yargs="-yarn_pattern rib1x1 -yarn_wales 3 -yarn_courses 3 -yls_relax 0 -options_file options/hang.opts -scene_duration 0.005 -yls_snes_max_it 1 -yls_max_halvings 0"
if timeout "$TIMEOUT" bin/volknit yls -o "$dy" $yargs > "$dy.log" 2>&1 \
   && grep -q 'yarn-level step 1 (t = 0.001 s) did not converge' "$dy.log" && grep -q '"status": "unconverged"' "$dy/yls.json"; then ok
else not_ok "volknit yls -yls_snes_max_it 1: expected a warning and status unconverged in yls.json (see $dy.log)"; fi
timeout "$TIMEOUT" bin/volknit yls -o "$dy" $yargs -yls_strict > "$dy.strict.log" 2>&1
rc=$?
if [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] && grep -q 'Yarn-level step 1 .*(-yls_strict)' "$dy.strict.log"; then ok
else not_ok "volknit yls -yls_snes_max_it 1 -yls_strict: expected a non-zero exit naming the step (status $rc, see $dy.strict.log)"; fi
# volknit report on the runs test_report wrote by hand (1 and 2 ranks)
tr="$out/test_report.n1"
for n in 1 2; do
  if timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/volknit report -report_yls "$tr/yls" -report_runs "$tr/same,$tr/shifted" -o "$out/report.n$n" > "$out/report.n$n.log" 2>&1 \
     && grep -q 'same: REL 0.000' "$out/report.n$n.log" && grep -q '"label": "shifted"' "$out/report.n$n/report.json" && [ -s "$out/report.n$n/report.md" ]; then ok
  else not_ok "volknit report -n $n on tests/out/test_report.n1 (see $out/report.n$n.log)"; fi
done
printf '%-22s       : %4d passed, %d failed\n' "mesh, 1 vs 2 ranks" "$((passed - cmp_passed))" "$((failed - cmp_failed))"

# 4. the example programs: ex1's printed mass balance and reproduction error,
#    ex2's stretch of the driven yarns (1.5 x the rest width)
for n in 1 2; do
  log="$out/ex1.n$n.log"
  timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/examples/ex1_chart_mesh -ex_chart meshes/moss_rib.knit -ex_wales 9 -ex_courses 7 -o "$out/ex1.n$n" > "$log" 2>&1
  rc=$?
  dm=$(sed -n 's/.*(relative difference \([^)]*\)).*/\1/p' "$log" | tail -n 1)
  dx=$(sed -n 's/.*reproduces the rest yarn to \([^ ]*\) m.*/\1/p' "$log")
  if [ "$rc" -eq 0 ] && [ -n "$dm" ] && [ -n "$dx" ] && awk -v a="$dm" -v b="$dx" 'BEGIN { exit !(a < 1e-12 && b < 3e-15) }'; then ok
  else not_ok "ex1_chart_mesh -n $n: status $rc, mass difference '$dm' (< 1e-12), reproduction '$dx' m (< 3e-15 = 1e-12 h) (see $log)"; fi
done
for n in 1 2; do
  log="$out/ex2.n$n.log"
  timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/examples/ex2_stretch -ts_dt 0.02 -o "$out/ex2.n$n" > "$log" 2>&1
  rc=$?
  ratio=$(sed -n 's/.*after the stretch (ratio \([^)]*\)).*/\1/p' "$log")
  if [ "$rc" -eq 0 ] && [ -n "$ratio" ] && [ -s "$out/ex2.n$n/sim.h5" ] && awk -v r="$ratio" 'BEGIN { exit !(r > 1.49 && r < 1.51) }'; then ok
  else not_ok "ex2_stretch -n $n: status $rc, width ratio '$ratio' (1.5 expected), sim.h5 written (see $log)"; fi
done
printf '%-22s       : examples ex1_chart_mesh, ex2_stretch with 1 and 2 ranks\n' "examples"

# 5. volknit run -run_fit -run_report on a small patch (2 x 2 rib, stretch):
#    yarn, yls, mesh, fit, sim and report, the fit the same as volknit fit's on its data; 1 and
#    2 ranks give the same material; a run stopped by -fit_max_iterations, or
#    killed, leaves no material.h5 and goes on with -fit_restart (also on
#    another rank count) to the material of the uninterrupted run; broken
#    checkpoints are refused without a material.h5 written.
fit_passed=$passed
fit_failed=$failed
fd="$out/fit"
# one option set for every fit mode (the trajectory loss reads no -fit_nsamples), so unread ones only warn
FIT_OPTS="-options_file options/stretch.opts -fit_nsamples 2 -fit_sample_by energy -fit_gd_its 3 -fit_gn_its 5 -fit_harmonic 1,10 -options_unused_ok"
json_num() { sed -n "s/.*\"$2\": \([^,]*\),\{0,1\}$/\1/p" "$1" | head -n "${3:-1}" | tail -n 1; }
compare_material() { # a b rtol what
  log="$fd/compare.$4.log"
  bin/tests/tool_compare_material "$1" "$2" "$3" > "$log" 2>&1
  rc=$?
  p=$(grep -c '^ok ' "$log"); f=$(grep -c '^not ok ' "$log")
  passed=$((passed + p)); failed=$((failed + f))
  grep '^not ok' "$log" | sed "s|^|fit, $4: |"
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then not_ok "fit, $4: tool_compare_material exited with status $rc (see $log)"; fi
}
fit_dir() { # name -> a fresh directory with the reference run's mesh.h5 and yls.h5
  rm -rf "${fd:?}/$1"; mkdir -p "$fd/$1"; cp "$fd/ref/mesh.h5" "$fd/ref/yls.h5" "$fd/$1/"
}
fit_run() { # name ranks [options]: volknit fit in $fd/name, log in $fd/name.log
  d=$1; n=$2; shift 2
  # shellcheck disable=SC2086
  timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/volknit fit -o "$fd/$d" $FIT_OPTS "$@" > "$fd/$d.log" 2>&1
}
mkdir -p "$fd"
# shellcheck disable=SC2086
if timeout "$TIMEOUT" bin/volknit run -run_fit -run_report -o "$fd/ref" $FIT_OPTS -yarn_pattern rib1x1 -yarn_wales 2 -yarn_courses 2 -scene_duration 0.1 > "$fd/ref.log" 2>&1 \
   && [ -s "$fd/ref/material.h5" ] && [ -s "$fd/ref/sim.h5" ] && grep -q 'stages yarn, yls, mesh, fit, sim, report done' "$fd/ref.log" \
   && grep -q '"label": "fitted"' "$fd/ref/report/report.json"; then
  ok
  # the run's summary line and run.json say whether the fit converged, as the fit's own status line does
  fst=$(sed -n 's/^volknit fit: status \([a-z]*\) .*/\1/p' "$fd/ref.log")
  if [ -n "$fst" ] && grep -q "(fit status: $fst, sim status: " "$fd/ref.log" && grep -q "\"fit_status\": \"$fst\"" "$fd/ref/run.json"; then ok
  else not_ok "volknit run -run_fit: expected the fit's status '$fst' on the run's summary line and in run.json (see $fd/ref.log)"; fi
  for n in 1 2; do
    fit_dir "n$n"
    if fit_run "n$n" "$n" && [ -s "$fd/n$n/material.h5" ] && [ -s "$fd/n$n/fit.csv" ] && [ -s "$fd/n$n/fit.json" ] && [ ! -e "$fd/n$n/fit_checkpoint.h5" ] \
       && grep -q '"fraction_of_g_v_on_it"' "$fd/n$n/fit.json" && grep -q 'on the parameter floor: [0-9]*% of g_s' "$fd/n$n.log"; then ok
    else not_ok "volknit fit -n $n: failed, an output or the parameter-floor report missing, or the checkpoint left behind (see $fd/n$n.log)"; fi
    # how each sample's stages ended: one stop per sample and stage in fit.json
    # (2 samples, stages r = 1, 10 and full), the status the same in the log,
    # and an unconverged fit warned about
    st=$(sed -n 's/^  "status": "\([a-z]*\)".*/\1/p' "$fd/n$n/fit.json")
    if [ "$(grep -c '"stop": "[a-z_]*"' "$fd/n$n/fit.json")" = 6 ] && [ -n "$st" ] && grep -q "^volknit fit: status $st (" "$fd/n$n.log" \
       && grep -q '; stages r = 1 [a-z_]*, r = 10 [a-z_]*, full [a-z_]*$' "$fd/n$n.log" \
       && { [ "$st" = converged ] || grep -q '^volknit fit: WARNING: .* sample stages .*not converged' "$fd/n$n.log"; }; then ok
    else not_ok "volknit fit -n $n: expected a stop per sample and stage in fit.json, its status '$st' in the log, and a warning when unconverged (see $fd/n$n.log)"; fi
  done
  # -fit_strict: fits that end unconverged with these options (either loss: the frames fit
  # above, the trajectory fit measured 1 of 2 stages converged) stop with an error and write
  # no material.h5
  for loss in frames trajectory; do
    fit_dir "strict.$loss"
    if [ "$(sed -n 's/^  "status": "\([a-z]*\)".*/\1/p' "$fd/n1/fit.json")" = unconverged ] && ! fit_run "strict.$loss" 1 -fit_loss "$loss" -fit_strict \
       && grep -q 'The fit did not converge (-fit_strict)' "$fd/strict.$loss.log" && [ ! -e "$fd/strict.$loss/material.h5" ]; then ok
    else not_ok "volknit fit -fit_loss $loss -fit_strict on an unconverged fit: expected an error naming -fit_strict and no material.h5 (see $fd/strict.$loss.log)"; fi
  done
  compare_material "$fd/ref/material.h5" "$fd/n1/material.h5" 1e-7 "volknit run -run_fit vs volknit fit"
  compare_material "$fd/n1/material.h5" "$fd/n2/material.h5" 1e-5 "1 vs 2 ranks"
  # the fit's PD with the CMS global solver (CG to 1e-10; measured 7e-11 from Cholesky's material)
  fit_dir "cms"
  if fit_run "cms" 2 -fit_pd_global_pc_type cms; then compare_material "$fd/n1/material.h5" "$fd/cms/material.h5" 1e-5 "-fit_pd_global_pc_type cms vs Cholesky"
  else not_ok "volknit fit -fit_pd_global_pc_type cms failed (see $fd/cms.log)"; fi
  # plain PD's CG over cms cut short (-pd_global_ksp_max_it 2, it needs about 9) fails the run: an error, status failed in sim.json
  rm -rf "$fd/cms.short"; mkdir -p "$fd/cms.short"; cp "$fd/ref/mesh.h5" "$fd/cms.short/"
  if ! timeout "$TIMEOUT" $MPIEXEC -n 2 bin/volknit sim -o "$fd/cms.short" -options_file options/stretch.opts -scene_duration 0.02 -pd_type pd -pd_global_pc_type cms -pd_global_ksp_max_it 2 > "$fd/cms.short.log" 2>&1 \
     && grep -q 'the global-step solver (-pd_global_) failed' "$fd/cms.short.log" && grep -q '"status": "failed"' "$fd/cms.short/sim.json"; then ok
  else not_ok "volknit sim -pd_type pd -pd_global_pc_type cms -pd_global_ksp_max_it 2: expected an error and status failed in sim.json (see $fd/cms.short.log)"; fi
  # the best uniform material first (-fit_best_uniform): reported, in fit.json
  fit_dir "uniform"
  if fit_run "uniform" 2 -fit_best_uniform && grep -q 'best uniform material g_s = g_v' "$fd/uniform.log" && grep -q '"best_uniform"' "$fd/uniform/fit.json" && [ -s "$fd/uniform/material.h5" ]; then ok
  else not_ok "volknit fit -fit_best_uniform: expected the search's line and best_uniform in fit.json (see $fd/uniform.log)"; fi
  # a best uniform at an end of the search range is flagged: the loss may fall further outside it
  fit_dir "uniform_edge"
  if fit_run "uniform_edge" 1 -fit_best_uniform -fit_uniform_range 1,3 && grep -q 'WARNING: the best uniform g = 1 Pa lies at the lower end of the search range \[1., 3.\] Pa' "$fd/uniform_edge.log" \
     && grep -q '"at_end_of_search_range": "lower"' "$fd/uniform_edge/fit.json"; then ok
  else not_ok "volknit fit -fit_uniform_range 1,3: expected a warning and at_end_of_search_range lower in fit.json (see $fd/uniform_edge.log)"; fi
  # the fit's PD reads its own options (prefix fit_): a global solver that
  # cannot converge given as -pd_global_ leaves the fit alone, as
  # -fit_pd_global_ it stops the fit with the option's name
  broken="pd_global_ksp_type cg -PFX_pd_global_pc_type none -PFX_pd_global_ksp_max_it 1"
  fit_dir "prefix.sim"
  fit_dir "prefix.fit"
  if fit_run "prefix.sim" 1 -fit_gn_its 1 -${broken//PFX_/} && [ -s "$fd/prefix.sim/material.h5" ] \
     && ! fit_run "prefix.fit" 1 -fit_gn_its 1 -fit_${broken//PFX_/fit_} && grep -q 'the PD global solve failed (see -fit_pd_global_ksp_converged_reason)' "$fd/prefix.fit.log"; then ok
  else not_ok "volknit fit: -pd_global_ options must not reach the fit's PD and -fit_pd_global_ ones must (see $fd/prefix.sim.log, $fd/prefix.fit.log)"; fi
  # the trajectory loss (-fit_loss trajectory): by default from the best uniform material
  # (searched, in fit.json), the rollout's loss falls by a tenth or more, the outputs say
  # which loss, and 1 and 2 ranks give the same material
  for n in 1 2; do
    fit_dir "traj$n"
    if fit_run "traj$n" "$n" -fit_loss trajectory && [ -s "$fd/traj$n/material.h5" ] && grep -q '"loss": "trajectory"' "$fd/traj$n/fit.json" \
       && grep -q '^volknit fit: best uniform material g_s = g_v = .* (trajectory loss' "$fd/traj$n.log" && grep -q '"trajectory_loss"' "$fd/traj$n/fit.json" \
       && sed -n 's/^volknit fit: trajectory loss \([^ ]*\) -> \([^ ]*\) .*/\1 \2/p' "$fd/traj$n.log" | awk 'NF == 2 && $2 < 0.9 * $1 { found = 1 } END { exit !found }'; then ok
    else not_ok "volknit fit -n $n -fit_loss trajectory: failed, no material.h5, no best-uniform search, or the loss did not fall by a tenth (see $fd/traj$n.log; measured: 19 %, with the handles holding their yarns' tets and the scene's drag)"; fi
    # its status: the same in fit.json and the log, and a stage cut at -fit_gn_its is warned about and unconverged
    st=$(sed -n 's/^  "status": "\([a-z]*\)".*/\1/p' "$fd/traj$n/fit.json")
    if [ -n "$st" ] && grep -q "^volknit fit: status $st " "$fd/traj$n.log" \
       && { ! grep -q '"stop": "iteration_limit"' "$fd/traj$n/fit.json" || { [ "$st" = unconverged ] && grep -q 'WARNING: stage r = .* stopped at -fit_gn_its' "$fd/traj$n.log"; }; }; then ok
    else not_ok "volknit fit -n $n -fit_loss trajectory: status '$st' in fit.json, its log line or the iteration-limit warning missing (see $fd/traj$n.log)"; fi
  done
  compare_material "$fd/traj1/material.h5" "$fd/traj2/material.h5" 1e-5 "trajectory, 1 vs 2 ranks"
  # a ceiling (-fit_gamma_max) twice the best uniform material: fit.json names
  # it, and no fitted parameter goes above it
  fit_dir "trajceil"
  if fit_run "trajceil" 2 -fit_loss trajectory -fit_gamma_max 2 && [ -s "$fd/trajceil/material.h5" ] \
     && awk -v c="$(json_num "$fd/trajceil/fit.json" g_s_Pa 2)" -v cv="$(json_num "$fd/trajceil/fit.json" g_v_Pa 2)" \
            -v l="$(json_num "$fd/trajceil/fit.json" largest_g_s_Pa)" -v lv="$(json_num "$fd/trajceil/fit.json" largest_g_v_Pa)" \
            -v u="$(json_num "$fd/trajceil/fit.json" gamma_Pa)" \
            'BEGIN { exit !(c > 0 && c <= 2.000001 * u && l > 0 && l <= c && lv > 0 && lv <= cv) }'; then ok
  else not_ok "volknit fit -fit_loss trajectory -fit_gamma_max 2: failed, or a parameter above the ceiling in fit.json (see $fd/trajceil.log, $fd/trajceil/fit.json)"; fi
  # one material on two scenes (-fit_joint): a hang run of the same yarn beside
  # the stretch; from 1 kPa (no search) the joint loss (the sum of the scenes'
  # normalized losses) falls and both scenes report theirs -- one scene may
  # give up some of its fit for the other -- and 1 and 2 ranks agree
  if timeout "$TIMEOUT" bin/volknit yls -o "$fd/hang" -yarn_h5 "$fd/ref/yarn.h5" -options_file options/hang.opts -scene_duration 0.1 > "$fd/hang.log" 2>&1; then
    for n in 1 2; do
      fit_dir "joint$n"
      if fit_run "joint$n" "$n" -fit_loss trajectory -fit_best_uniform 0 -fit_joint "$fd/hang" -prefix_push fit_joint1_ -options_file options/hang.opts -prefix_pop \
         && [ -s "$fd/joint$n/material.h5" ] && grep -q '"joint_data"' "$fd/joint$n/fit.json" \
         && [ "$(grep -c '^volknit fit: trajectory of .*: loss .* -> .* (at rest' "$fd/joint$n.log")" = 2 ] \
         && sed -n 's/^volknit fit: trajectory loss \([^ ]*\) -> \([^ ]*\) (of its excess.*/\1 \2/p' "$fd/joint$n.log" | awk 'NF == 2 && $2 < $1 { down++ } END { exit down != 1 }'; then ok
      else not_ok "volknit fit -n $n -fit_joint: failed, no material.h5, no joint_data in fit.json, a scene's loss not reported, or the joint loss did not fall (see $fd/joint$n.log)"; fi
      # the same with the coupling, g_c fitted per tet on both scenes at once
      fit_dir "jointc$n"
      if fit_run "jointc$n" "$n" -mat_coupling 2000 -fit_loss trajectory -fit_best_uniform 0 -fit_joint "$fd/hang" -prefix_push fit_joint1_ -options_file options/hang.opts -prefix_pop \
         && [ -s "$fd/jointc$n/material.h5" ] && grep -q '"coupling_fitted": true' "$fd/jointc$n/fit.json" \
         && [ "$(grep -c '^volknit fit: trajectory of .*: loss .* -> .* (at rest' "$fd/jointc$n.log")" = 2 ] \
         && sed -n 's/^volknit fit: trajectory loss \([^ ]*\) -> \([^ ]*\) (of its excess.*/\1 \2/p' "$fd/jointc$n.log" | awk 'NF == 2 && $2 < $1 { down++ } END { exit down != 1 }'; then ok
      else not_ok "volknit fit -n $n -fit_joint -mat_coupling 2000: failed, no material.h5, g_c not fitted, a scene's loss not reported, or the joint loss did not fall (see $fd/jointc$n.log)"; fi
    done
    compare_material "$fd/joint1/material.h5" "$fd/joint2/material.h5" 1e-5 "joint, 1 vs 2 ranks"
    compare_material "$fd/jointc1/material.h5" "$fd/jointc2/material.h5" 1e-5 "joint with g_c fitted, 1 vs 2 ranks"
    for case in "frames:-fit_joint fits trajectories of several scenes: give -fit_loss trajectory" "missing:/nonexistent/yls.h5" "five:a list of 1 to 4 directories"; do
      kind=${case%%:*}; expect=${case#*:}
      fit_dir "joint.$kind"
      case "$kind" in
        frames) fit_run "joint.$kind" 1 -fit_joint "$fd/hang" ;;
        missing) fit_run "joint.$kind" 1 -fit_loss trajectory -fit_joint /nonexistent ;;
        five) fit_run "joint.$kind" 1 -fit_loss trajectory -fit_joint "$fd/hang,$fd/hang,$fd/hang,$fd/hang,$fd/hang" ;;
      esac
      rc=$?
      if [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] && grep -q -- "$expect" "$fd/joint.$kind.log" && [ ! -e "$fd/joint.$kind/material.h5" ]; then ok
      else not_ok "volknit fit -fit_joint ($kind): status $rc, expected '$expect' and no material.h5 (see $fd/joint.$kind.log)"; fi
    done
  else not_ok "the hang run for the -fit_joint tests failed (see $fd/hang.log)"; fi
  # the stretch band material (-mat_band): fitted, carried by material.h5 into
  # volknit sim, and refused there beside another -mat_band
  fit_dir "band"
  if fit_run "band" 2 -mat_band 0.9,1.1 && [ -s "$fd/band/material.h5" ] \
     && timeout "$TIMEOUT" $MPIEXEC -n 2 bin/volknit sim -o "$fd/band" -mat_file "$fd/band/material.h5" -scene_duration 0.02 -sim_view > "$fd/band.sim.log" 2>&1 \
     && grep -q 'clamp(s, 0.9, 1.1)' "$fd/band.sim.log"; then ok
  else not_ok "volknit fit -mat_band 0.9,1.1 then sim -mat_file: expected the band in the sim's material (see $fd/band.log, $fd/band.sim.log)"; fi
  rm -rf "$fd/band.conflict"; mkdir -p "$fd/band.conflict"; cp "$fd/ref/mesh.h5" "$fd/band.conflict/"
  if ! timeout "$TIMEOUT" bin/volknit sim -o "$fd/band.conflict" -mat_file "$fd/band/material.h5" -mat_band 0.8,1.2 -scene_duration 0.02 > "$fd/band.conflict.log" 2>&1 \
     && grep -q 'conflicts with the band 0.9,1.1' "$fd/band.conflict.log" && [ "$(ls "$fd/band.conflict")" = "mesh.h5" ]; then ok
  else not_ok "volknit sim -mat_band 0.8,1.2 with a material fitted at 0.9,1.1: expected a refusal and no output (see $fd/band.conflict.log)"; fi
  # the stretch-to-bending coupling (-mat_coupling): g_s, g_v and g_c per tet
  # fitted the same on 1 and 2 ranks, carried by material.h5 into volknit
  # sim, accepted there beside the same -mat_coupling, refused beside
  # another; with -fit_coupling 0 g_c stays as given
  for n in 1 2; do
    fit_dir "coupling$n"
    if fit_run "coupling$n" "$n" -mat_coupling 2000 && [ -s "$fd/coupling$n/material.h5" ] && grep -q '"coupling_fitted": true' "$fd/coupling$n/fit.json"; then ok
    else not_ok "volknit fit -n $n -mat_coupling 2000: failed, no material.h5 or g_c not fitted (see $fd/coupling$n.log)"; fi
  done
  compare_material "$fd/coupling1/material.h5" "$fd/coupling2/material.h5" 1e-5 "coupling, 1 vs 2 ranks"
  if timeout "$TIMEOUT" $MPIEXEC -n 2 bin/volknit sim -o "$fd/coupling2" -options_file options/hang.opts -mat_file "$fd/coupling2/material.h5" -scene_duration 0.02 -sim_view > "$fd/coupling.sim.log" 2>&1 \
     && range=$(sed -n 's/.*stretch-to-bending coupling): g_c in \[\([^,]*\), \([^]]*\)\] Pa, nu in \[0., 1.5\].*/\1 \2/p' "$fd/coupling.sim.log") \
     && [ -n "$range" ] && awk -v r="$range" 'BEGIN { split(r, a, " "); exit !(a[1] > 0 && a[1] < a[2]) }' \
     && grep -q 'converged in every step' "$fd/coupling.sim.log"; then ok
  else not_ok "volknit sim -mat_file of a fit with -mat_coupling 2000: expected a fitted g_c that varies over the tets (got '$range'), nu 0 and 1.5 by face, and every step converged (see $fd/coupling.sim.log)"; fi
  if timeout "$TIMEOUT" bin/volknit sim -o "$fd/coupling1" -mat_file "$fd/coupling1/material.h5" -mat_coupling 2000 -scene_duration 0.02 > "$fd/coupling.same.log" 2>&1; then ok
  else not_ok "volknit sim -mat_coupling 2000 with a material fitted from that coupling: expected it accepted, as volknit run passes both (see $fd/coupling.same.log)"; fi
  fit_dir "coupling.fixed"
  if fit_run "coupling.fixed" 1 -mat_coupling 2000 -fit_coupling 0 && grep -q '"coupling_fitted": false' "$fd/coupling.fixed/fit.json" \
     && timeout "$TIMEOUT" bin/volknit sim -o "$fd/coupling.fixed" -mat_file "$fd/coupling.fixed/material.h5" -scene_duration 0.02 -sim_view > "$fd/coupling.fixed.sim.log" 2>&1 \
     && grep -qF 'stretch-to-bending coupling): g_c in [2000., 2000.] Pa' "$fd/coupling.fixed.sim.log"; then ok
  else not_ok "volknit fit -mat_coupling 2000 -fit_coupling 0: expected g_c left at 2000 Pa on every tet (see $fd/coupling.fixed.log, $fd/coupling.fixed.sim.log)"; fi
  d="coupling.stop"; fit_dir "$d" # a checkpoint of a fit with g_c held, for the broken-checkpoint cases below
  fit_run "$d" 1 -mat_coupling 2000 -fit_coupling 0 -fit_max_iterations 3 -fit_checkpoint_every 2
  cp "$fd/$d/fit_checkpoint.h5" "$fd/checkpoint.coupling.h5" 2> /dev/null
  # projections stopped short (no Newton step allowed): every such step is
  # unconverged, warned about and counted in sim.json; an error with -sim_strict
  rm -rf "$fd/coupling.short"; mkdir -p "$fd/coupling.short"; cp "$fd/ref/mesh.h5" "$fd/coupling.short/"
  if timeout "$TIMEOUT" bin/volknit sim -o "$fd/coupling.short" -options_file options/stretch.opts -mat_coupling 2000 -mat_coupling_max_it 0 -scene_duration 0.05 > "$fd/coupling.short.log" 2>&1 \
     && grep -q 'did not converge (PROJECTION_SHORT)' "$fd/coupling.short.log" && grep -q '"status": "unconverged"' "$fd/coupling.short/sim.json" \
     && grep -Eq '"steps_projection_short": [1-9]' "$fd/coupling.short/sim.json"; then ok
  else not_ok "volknit sim -mat_coupling_max_it 0: expected PROJECTION_SHORT warnings, status unconverged and steps_projection_short in sim.json (see $fd/coupling.short.log)"; fi
  if ! timeout "$TIMEOUT" bin/volknit sim -o "$fd/coupling.short" -options_file options/stretch.opts -mat_coupling 2000 -mat_coupling_max_it 0 -scene_duration 0.05 -sim_strict > "$fd/coupling.strict.log" 2>&1 \
     && grep -q 'raise -mat_coupling_max_it' "$fd/coupling.strict.log"; then ok
  else not_ok "volknit sim -mat_coupling_max_it 0 -sim_strict: expected an error naming -mat_coupling_max_it (see $fd/coupling.strict.log)"; fi
  rm -rf "$fd/coupling.conflict"; mkdir -p "$fd/coupling.conflict"; cp "$fd/ref/mesh.h5" "$fd/coupling.conflict/"
  if ! timeout "$TIMEOUT" bin/volknit sim -o "$fd/coupling.conflict" -mat_file "$fd/coupling1/material.h5" -mat_coupling 10 -scene_duration 0.02 > "$fd/coupling.conflict.log" 2>&1 \
     && grep -q 'conflicts with the coupling of' "$fd/coupling.conflict.log" && [ "$(ls "$fd/coupling.conflict")" = "mesh.h5" ]; then ok
  else not_ok "volknit sim -mat_coupling 10 with a material fitted with a coupling: expected a refusal and no output (see $fd/coupling.conflict.log)"; fi
  # stopped, then restarted: with the same rank count, and with the other
  # (the restart re-converges its equilibria from the checkpoint, so even on
  # the same ranks it agrees to solver tolerance, not bit for bit: 1.4e-7
  # measured on the reference run of the tight yls Hessian pattern)
  for case in "1 1 1e-6" "2 1 1e-5"; do
    set -- $case
    d="stop.n$1.n$2"; fit_dir "$d"
    fit_run "$d" "$1" -fit_max_iterations 9 -fit_checkpoint_every 4
    rc=$?
    if [ "$rc" -eq 0 ] && [ ! -e "$fd/$d/material.h5" ] && [ -s "$fd/$d/fit_checkpoint.h5" ] && grep -q 'stopped after 9 iterations' "$fd/$d.log"; then ok
    else not_ok "fit -n $1 -fit_max_iterations 9: status $rc, expected a checkpoint, no material.h5 (see $fd/$d.log)"; fi
    mv "$fd/$d.log" "$fd/$d.first.log"
    cp "$fd/$d/fit_checkpoint.h5" "$fd/checkpoint.$d.h5" 2> /dev/null
    if fit_run "$d" "$2" -fit_restart && grep -q 'resuming' "$fd/$d.log"; then compare_material "$fd/n$2/material.h5" "$fd/$d/material.h5" "$3" "stopped on $1 rank(s), restarted on $2"
    else not_ok "fit -n $2 -fit_restart after a stop on $1 rank(s) failed (see $fd/$d.log)"; fi
    # the stages ended before the stop keep their reasons through the checkpoint
    if [ "$(grep -o '"stop": "[a-z_]*"' "$fd/$d/fit.json")" = "$(grep -o '"stop": "[a-z_]*"' "$fd/n$2/fit.json")" ]; then ok
    else not_ok "fit -fit_restart after a stop on $1 rank(s): the stages' stop reasons differ from the uninterrupted fit's (see $fd/$d/fit.json, $fd/n$2/fit.json)"; fi
  done
  # killed (SIGKILL) once a checkpoint exists: no material.h5, and the restart still gets there
  d="killed"; fit_dir "$d"
  # shellcheck disable=SC2086
  bin/volknit fit -o "$fd/$d" $FIT_OPTS -fit_checkpoint_every 1 > "$fd/$d.first.log" 2>&1 &
  pid=$!
  for _ in $(seq 1 600); do [ -e "$fd/$d/fit_checkpoint.h5" ] && break; sleep 0.05; done
  kill -9 "$pid" 2> /dev/null; wait "$pid" 2> /dev/null
  if [ ! -e "$fd/$d/material.h5" ] && [ -e "$fd/$d/fit_checkpoint.h5" ]; then ok
  else not_ok "fit killed after its first checkpoint: expected the checkpoint and no material.h5 (see $fd/$d.first.log)"; fi
  # the kill lands anywhere, so the restart may re-converge an equilibrium the run had left at its
  # tolerance: the same gamma to solver tolerance, as for 1 vs 2 ranks (measured 6e-11 .. 1.3e-7)
  if fit_run "$d" 1 -fit_restart; then compare_material "$fd/n1/material.h5" "$fd/$d/material.h5" 1e-5 "killed, restarted"
  else not_ok "fit -fit_restart after a kill failed (see $fd/$d.log)"; fi
  # broken checkpoints: refused with a message, no material.h5
  for case in "truncated:HDF5 file" "other:attribute format of /checkpoint is missing" "missing:no checkpoint" "band:this one has 0.9,1.1 (give the same -mat_band)" "coupling:another stretch-to-bending coupling" "gc:did not fit the coupling's g_c; this one fits it"; do
    kind=${case%%:*}; expect=${case#*:}; extra=""
    d="broken.$kind"; fit_dir "$d"
    case "$kind" in
      truncated) head -c 3000 "$fd/checkpoint.stop.n1.n1.h5" > "$fd/$d/fit_checkpoint.h5" ;;
      other) cp "$fd/ref/yls.h5" "$fd/$d/fit_checkpoint.h5" ;;
      band) cp "$fd/checkpoint.stop.n1.n1.h5" "$fd/$d/fit_checkpoint.h5"; extra="-mat_band 0.9,1.1" ;; # written without a band
      coupling) cp "$fd/checkpoint.stop.n1.n1.h5" "$fd/$d/fit_checkpoint.h5"; extra="-mat_coupling 2000" ;; # written without a coupling
      gc) cp "$fd/checkpoint.coupling.h5" "$fd/$d/fit_checkpoint.h5"; extra="-mat_coupling 2000" ;; # written by a fit with -fit_coupling 0
    esac
    # shellcheck disable=SC2086
    fit_run "$d" 2 -fit_restart $extra
    rc=$?
    if [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] && grep -q "$expect" "$fd/$d.log" && [ ! -e "$fd/$d/material.h5" ] && ! grep -qiE 'segmentation|caught signal' "$fd/$d.log"; then ok
    else not_ok "fit -fit_restart with a $kind checkpoint: status $rc, message '$expect', no material.h5 expected (see $fd/$d.log)"; fi
  done
else
  not_ok "volknit run -run_fit (the reference run of the fit tests) failed or left no material.h5/sim.h5 (see $fd/ref.log)"
fi
# -help lists the sample-frame options too, which are read once the data are loaded
if timeout "$TIMEOUT" bin/volknit fit -help > "$fd/help.log" 2>&1 && grep -q -- '-fit_nsamples <' "$fd/help.log" && grep -q -- '-fit_sample_by <' "$fd/help.log" && grep -q -- '-fit_frames <' "$fd/help.log"; then ok
else not_ok "volknit fit -help: does not list -fit_nsamples, -fit_sample_by and -fit_frames (see $fd/help.log)"; fi
printf '%-22s       : %4d passed, %d failed\n' "fit command" "$((passed - fit_passed))" "$((failed - fit_failed))"

# 6. volknit run sweeps on the 2 x 2 rib stretch: the best uniform material's
#    predicted REL (its trajectory loss) is what volknit report measures of
#    its run; 1 and 2 ranks find the same material and error; a second run
#    with the same reference options does not rerun the yarn-level reference,
#    a changed -yls_ option or a reference of another model does; mesh, step and PD-iteration lists give
#    one point each, with frames on the output interval (the report matches
#    them to the reference's).
run_passed=$passed
run_failed=$failed
rd="$out/run"
mkdir -p "$rd"
SWEEP_OPTS="-options_file options/stretch.opts -yarn_pattern rib1x1 -yarn_wales 2 -yarn_courses 2 -scene_duration 0.1"
close() { awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; s = (a < 0 ? -a : a); exit !(a != "" && b != "" && d <= t * s) }'; }
sweep_run() { # dir ranks [options]: volknit run, log in dir.log
  d=$1; n=$2; shift 2
  # shellcheck disable=SC2086
  timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/volknit run -o "$rd/$d" $SWEEP_OPTS "$@" > "$rd/$d.log" 2>&1
}
for n in 1 2; do
  if sweep_run "s$n" "$n" -run_sweep_material uniform,best_uniform && [ "$(grep -c '"label"' "$rd/s$n/report/report.json")" -eq 2 ] && [ -s "$rd/s$n/run.json" ]; then
    pred=$(json_num "$rd/s$n/run.json" best_uniform_predicted_rel); rel=$(json_num "$rd/s$n/report/report.json" rel 2)
    if close "$pred" "$rel" 1e-3 && grep -q '"label": "best_uniform"' "$rd/s$n/report/report.json"; then ok
    else not_ok "run sweep -n $n: the best uniform material's predicted REL $pred is not the REL $rel the report measured of its run"; fi
  else not_ok "run sweep -n $n (uniform, best_uniform) failed or left no report of 2 runs and run.json (see $rd/s$n.log)"; fi
done
# with the coupling the best uniform material refines g_c too, and the run
# of it is the material whose REL the search predicted
if sweep_run "sc" 1 -mat_coupling 2000 -run_sweep_material best_uniform && gc=$(json_num "$rd/sc/run.json" best_uniform_coupling_Pa) && [ -n "$gc" ] \
   && close "$(json_num "$rd/sc/run.json" best_uniform_predicted_rel)" "$(json_num "$rd/sc/report/report.json" rel 1)" 1e-3; then ok
else not_ok "run sweep -mat_coupling 2000: expected a refined uniform g_c ('$gc') whose predicted REL is the one measured (see $rd/sc.log)"; fi
for key in best_uniform_gamma_s_Pa best_uniform_gamma_v_Pa; do
  if close "$(json_num "$rd/s1/run.json" $key)" "$(json_num "$rd/s2/run.json" $key)" 1e-5; then ok
  else not_ok "run sweep: $key differs between 1 and 2 ranks ($(json_num "$rd/s1/run.json" $key) and $(json_num "$rd/s2/run.json" $key))"; fi
done
if close "$(json_num "$rd/s1/report/report.json" rel 1)" "$(json_num "$rd/s2/report/report.json" rel 1)" 1e-6; then ok
else not_ok "run sweep: the uniform material's REL differs between 1 and 2 ranks"; fi
# every dataset the XDMF files of runs on 1 and 2 ranks name (yarn, yls,
# mesh, sim; yarns as one polyline per curve) exists with the stated shape
xdmf_problems() { # file.xdmf: one line per DataItem whose dataset is missing or has another shape
  local dir; dir=$(dirname "$1")
  sed -n 's/.*Dimensions="\([0-9 ]*\)".*>\([^:<]*\):\([^<]*\)<.*/\1|\2|\3/p' "$1" | sort -u | while IFS='|' read -r dims file path; do
    shape=$(h5ls "$dir/$file$path" 2>/dev/null | sed -n 's/.*Dataset {\([^}]*\)}.*/\1/p' | tr -d ',')
    [ "$shape" = "$dims" ] || echo "$1: $file:$path is {$shape}, Dimensions \"$dims\""
  done
}
for n in 1 2; do
  files=$(find "$rd/s$n" -name '*.xdmf' | sort)
  problems=$(for f in $files; do xdmf_problems "$f"; done)
  nfiles=$(echo "$files" | grep -c xdmf)
  if [ "$nfiles" -ge 4 ] && [ -z "$problems" ] && grep -q 'TopologyType="Mixed"' "$rd/s$n/yls.xdmf" "$rd/s$n/yarn.xdmf"; then ok
  else not_ok "XDMF of the -n $n run ($nfiles files): $problems"; fi
done
# the preview pictures of the 2-rank run's yarn-level and homogenized
# runs: valid PNG files (signature), not blank (variance of the red
# channel, read back by gnuplot), named in the JSON summaries
png_variance() { # file.png: the variance of its red channel
  gnuplot -e "set table '$1.txt'; plot '$1' binary filetype=png with rgbimage; unset table" > /dev/null 2>&1
  awk 'NF >= 5 && $1 + 0 == $1 { n++; s += $3; q += $3 * $3 } END { if (n) print q / n - (s / n) ^ 2; else print 0 }' "$1.txt"
  rm -f "$1.txt"
}
for pv in "$rd/s2/yls_preview.png:$rd/s2/yls.json" "$(find "$rd/s2/sweep" -name sim_preview.png | head -n 1):$(dirname "$(find "$rd/s2/sweep" -name sim_preview.png | head -n 1)")/sim.json"; do
  png=${pv%%:*}; js=${pv#*:}
  sig=$(head -c 8 "$png" 2>/dev/null | od -An -tx1 | tr -d ' \n')
  var=$(png_variance "$png")
  if [ "$sig" = "89504e470d0a1a0a" ] && awk -v v="$var" 'BEGIN { exit !(v > 100) }' && grep -q '"preview": "[a-z]*_preview.png"' "$js"; then ok
  else not_ok "preview picture $png: signature '$sig', red-channel variance '$var' (> 100 expected), named in $js"; fi
done
# the sweep with the yarn-level reference draws each point's embedded
# yarns over the yarn-level ones: a valid, non-blank PNG named in run.json
cp="$rd/s2/sweep/uniform/compare_preview.png"
sig=$(head -c 8 "$cp" 2>/dev/null | od -An -tx1 | tr -d ' \n')
if [ "$sig" = "89504e470d0a1a0a" ] && awk -v v="$(png_variance "$cp")" 'BEGIN { exit !(v > 100) }' && grep -q '"compare_preview": "compare_preview.png"' "$rd/s2/run.json"; then ok
else not_ok "compare preview $cp: signature '$sig', not blank, named in $rd/s2/run.json"; fi
# volknit render on 1 and 2 ranks: one picture per frame of the 2-rank
# run's yls.h5 and of a sim.h5 of its sweep (every 2nd with -render_every
# 2), each a valid PNG, the first not blank, first and last different;
# with ffmpeg installed, a video with one frame per picture
sd=$(dirname "$(find "$rd/s2/sweep" -name sim.h5 | head -n 1)")
for n in 1 2; do
  for case in "yls:$rd/s2:1" "sim:$sd:1" "sim:$sd:2"; do
    src=${case%%:*}; rest=${case#*:}; d=${rest%:*}; every=${rest##*:}
    rm -rf "$d/render_$src"
    frames=$(json_num "$d/$src.json" frames)
    want=$(( (frames + every - 1) / every ))
    if timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/volknit render -o "$d" -render_source "$src" -render_every "$every" > "$d/render_$src.log" 2>&1; then
      count=$(find "$d/render_$src" -name 'frame_*.png' | wc -l)
      first="$d/render_$src/frame_000000.png"; last="$d/render_$src/frame_$(printf %06d $((count - 1))).png"
      sigs=$(for f in "$d/render_$src"/frame_*.png; do head -c 8 "$f" | od -An -tx1 | tr -d ' \n'; echo; done | sort -u)
      var=$(png_variance "$first")
      if [ "$count" = "$want" ] && [ "$sigs" = "89504e470d0a1a0a" ] && awk -v v="$var" 'BEGIN { exit !(v > 100) }' && ! cmp -s "$first" "$last"; then ok
      else not_ok "render -n $n $src every $every: $count pictures for $frames frames (want $want), signatures '$sigs', variance '$var' (> 100), first and last must differ"; fi
      if command -v ffprobe > /dev/null; then
        vf=$(ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames -of csv=p=0 "$d/render_$src/movie.mp4" 2>/dev/null)
        if [ "$vf" = "$want" ]; then ok; else not_ok "render -n $n $src: movie.mp4 has '$vf' frames, want $want"; fi
      fi
    else not_ok "volknit render -n $n -render_source $src failed (see $d/render_$src.log)"; fi
  done
done
# tools/paraview/volknit_view.py where ParaView's pvpython is installed
# (under xvfb-run without a display): a ParaView state and a valid,
# non-blank picture of the yarn-level run and of a homogenized run; exit 2
# with a message for a directory without a run and for an unknown field
pv=""
if command -v pvpython > /dev/null; then
  if [ -n "${DISPLAY:-}" ]; then pv="pvpython"; elif command -v xvfb-run > /dev/null; then pv="xvfb-run -a pvpython"; fi
fi
# Xvfb started by xvfb-run can refuse the first connection on a loaded
# machine ("bad X server connection"): that is the display, not the
# script, so such a run is tried once more.
pv_view() { timeout "$TIMEOUT" $pv tools/paraview/volknit_view.py "$1" --screenshot "$1/paraview.png" --size 800,400 > "$1/paraview.log" 2>&1; }
if [ -n "$pv" ]; then
  for d in "$rd/s2" "$sd"; do
    rm -f "$d/volknit.pvsm" "$d/paraview.png"
    if { pv_view "$d" || { grep -q "bad X server connection" "$d/paraview.log" && pv_view "$d"; }; } && [ -s "$d/volknit.pvsm" ] \
       && [ "$(head -c 8 "$d/paraview.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] && awk -v v="$(png_variance "$d/paraview.png")" 'BEGIN { exit !(v > 100) }'; then ok
    else not_ok "volknit_view.py $d: no state or no valid, non-blank picture (see $d/paraview.log)"; fi
  done
  mkdir -p "$rd/norun"
  for case in "$rd/norun::neither sim.xdmf nor yls.xdmf" "$sd:--field nosuch:no field 'nosuch'; the fields are"; do
    d=${case%%:*}; rest=${case#*:}; opt=${rest%%:*}; msg=${rest#*:}
    timeout "$TIMEOUT" $pv tools/paraview/volknit_view.py "$d" $opt --state none > "$rd/norun/pv.log" 2>&1; rc=$?
    if [ "$rc" = 2 ] && grep -q "$msg" "$rd/norun/pv.log"; then ok
    else not_ok "volknit_view.py $d $opt: exit $rc (want 2) and '$msg' (see $rd/norun/pv.log)"; fi
  done
fi
stamp=$(stat -c %Y "$rd/s1/yls.h5" 2>/dev/null)
if sweep_run "s1" 1 -run_sweep_material uniform && grep -q 'is up to date' "$rd/s1.log" && ! grep -q '^volknit yls: [0-9]* vertices' "$rd/s1.log" && [ "$(stat -c %Y "$rd/s1/yls.h5")" = "$stamp" ]; then ok
else not_ok "run sweep: the same reference options reran the yarn-level reference (see $rd/s1.log)"; fi
# a reference made by another yarn-level model (its stamp's first line) is made again
if head -n 1 "$rd/s2/reference.stamp" | grep -q '^yarn-level model: ' && sed -i '1s/.*/yarn-level model: unsigned curvature (before 2026-11)/' "$rd/s2/reference.stamp" \
   && sweep_run "s2" 1 -run_sweep_material uniform && grep -q '^volknit yls: [0-9]* vertices' "$rd/s2.log" && head -n 1 "$rd/s2/reference.stamp" | grep -q 'discrete elastic rods'; then ok
else not_ok "run sweep: a reference stamped by another yarn-level model was not made again (see $rd/s2.log)"; fi
if sweep_run "s1" 1 -run_sweep_material uniform -run_sweep_mesh_h 0.003,0.004 -run_sweep_ts_dt 0.005 -run_sweep_pd_its 3 -yls_strict \
   && grep -q '^volknit yls: [0-9]* vertices' "$rd/s1.log" && [ "$(grep -c '"label"' "$rd/s1/report/report.json")" -eq 2 ] \
   && grep -q '"label": "h0.004_uniform_dt0.005_its3"' "$rd/s1/report/report.json" && [ -s "$rd/s1/sweep/mesh_h0.004/mesh.h5" ] \
   && grep -q 'steps of 0.0047619 s instead' "$rd/s1.log"; then ok
else not_ok "run sweep over mesh h, dt and PD iterations with a changed -yls_ option: expected the reference rerun and a report of 2 runs (see $rd/s1.log)"; fi
printf '%-22s       : %4d passed, %d failed\n' "run sweeps" "$((passed - run_passed))" "$((failed - run_failed))"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
