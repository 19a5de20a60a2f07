#!/usr/bin/env bash
# The bad-input suite (issue 12): every test that checks a refused input through
# tests/bad_input.py (exit 2, one stderr line naming the file and the field), run in one
# pytest session, and the tally it prints:
#   figure | goal | ok?
#   bad-input suite: N cases, M gave exit 2 with one line naming the file | all | ok
# followed by each case that did not (none, when ok).
# Usage: bench/bad_input.sh [BUILD]   (default build; needs `make build`)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=$(cd "${1:-$root/build}" && pwd)
mapfile -t files < <(grep -lE "^from (bad_input|formats_helpers) import" "$root"/tests/*/test_*.py)
log=$(mktemp)
trap 'rm -f "$log"' EXIT
set +e
(cd "$root/tests" && BURRBENCH=$build/apps/burrbench BURRBENCH_SOURCE_DIR=$root BURRBENCH_BUILD_DIR=$build \
   /usr/bin/python3 -m pytest -q -p no:cacheprovider "${files[@]}") >"$log" 2>&1
rc=$?
set -e
tally=$(grep '^bad-input suite:' "$log" || true)
if [[ -z $tally ]]; then
  cat "$log" >&2
  echo "bad_input.sh: no tally (pytest exit $rc)" >&2
  exit 1
fi
read -r cases ok < <(sed -E 's/^bad-input suite: ([0-9]+) cases, ([0-9]+) gave.*/\1 \2/' <<<"$tally")
printf '%-90s | %-4s | %s\n' "figure (${#files[@]} test files)" "goal" "ok?"
printf '%-90s | %-4s | %s\n' "$tally" "all" "$([[ $cases == "$ok" && $rc -eq 0 ]] && echo ok || echo NO)"
grep '^  not so:' "$log" || true
[[ $rc -eq 0 ]] || { grep -E '^(FAILED|ERROR)' "$log" >&2 || true; exit 1; }
