#!/bin/bash
# tests/fuzz/run_fuzz.sh SECONDS: runs every libFuzzer target (bin/fuzz/*)
# for SECONDS each, seeded with the sample and broken inputs of the
# matching format; corpora and crash artifacts go to tests/out/fuzz/.
set -u
cd "$(dirname "$0")/../.."
T=${1:-60}
status=0
for bin in bin/fuzz/fuzz_*; do
  case "$bin" in *.d) continue ;; esac   # the compiler's dependency lists
  name=$(basename "$bin")
  fmt=${name#fuzz_}
  corpus=tests/out/fuzz/$fmt
  mkdir -p "$corpus"
  case "$fmt" in
    bcc)   seeds="meshes/*.bcc tests/bad/*.bcc" ;;
    pyp)   seeds="meshes/*.pyp tests/bad/*.pyp" ;;
    chart) seeds="meshes/*.knit tests/bad/*.knit" ;;
    weave) seeds="meshes/*.weave tests/bad/*.weave" ;;
    *)     seeds="" ;;
  esac
  for s in $seeds; do [ -f "$s" ] && cp "$s" "$corpus/"; done
  echo "== $name: $T s"
  ASAN_OPTIONS=detect_leaks=1:fast_unwind_on_malloc=0 LSAN_OPTIONS=suppressions=tests/fuzz/lsan.supp "$bin" -max_total_time="$T" -max_len=65536 -print_final_stats=1 \
    -artifact_prefix=tests/out/fuzz/"$fmt"- "$corpus" 2>&1 | grep -E 'stat::number_of_executed_runs|ERROR|SUMMARY|Done' | head -5
  [ "${PIPESTATUS[0]}" -eq 0 ] || { echo "$name FAILED (artifacts in tests/out/fuzz/)"; status=1; }
done
exit $status
