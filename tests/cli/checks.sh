# Shared by the command-line test scripts (sourced): a work directory removed at exit, failure
# counting, and `expect`.
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok: $*"; }

# expect CODE PATTERN -- command...: exit code CODE and PATTERN (grep -E) in stdout+stderr.
expect() {
  local code=$1 pattern=$2
  shift 3
  local out rc
  out=$("$@" 2>&1)
  rc=$?
  if [ "$rc" -ne "$code" ]; then
    fail "'$*' exited $rc, expected $code; output: ${out:0:400}"
  elif ! grep -Eiq -- "$pattern" <<<"$out"; then
    fail "'$*' output lacks /$pattern/: ${out:0:400}"
  fi
  if [ "$rc" -ge 128 ]; then fail "'$*' crashed (signal $((rc - 128)))"; fi
}
