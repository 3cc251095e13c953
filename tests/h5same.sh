# shellcheck shell=bash disable=SC2034
# tests/h5same.sh, sourced by tests/run_tests.sh and tests/bench/run_bench.sh:
#   h5same [h5diff options] A.h5 B.h5 OBJECT [OBJECT]
# succeeds when h5diff finds the objects equal (to its -d tolerance, if
# given) and fails otherwise, saying why in $h5same_said.  h5diff alone
# exits 0 on datasets of different sizes, saying only that some objects
# are not comparable: here that is a difference.
h5same() {
  local said rc
  said=$(h5diff "$@" 2>&1)
  rc=$?
  if grep -q "not comparable" <<< "$said"; then
    h5same_said="not comparable (different sizes or types)"
    return 1
  fi
  h5same_said=$(tail -1 <<< "$said")
  return $rc
}
