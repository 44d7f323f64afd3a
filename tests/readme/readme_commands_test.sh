#!/usr/bin/env bash
# readme_commands test: runs every shell code block of the README (```sh, ```bash, ```shell), in
# order, each as a `bash -e -o pipefail` script, in a scratch folder that looks like the clone
# after its build (every top-level entry of SOURCE_DIR linked, build/ -> BUILD_DIR). The first
# block that fails fails the test. ```ini blocks are loaded by `shape-slam run --config BLOCK
# --print-config`; ```cpp (built by install_consumer), ```cmake and ```text blocks are listed,
# not run. A fence without a language is an error. A block is left out only when the line right
# above it is
#   <!-- readme-test: skip REASON -->
# and every block left out is reported with its reason.
#   readme_commands_test.sh README SOURCE_DIR BUILD_DIR WORK_DIR
#   readme_commands_test.sh --self-test WORK_DIR
#       (a README whose second block fails must fail; one with a fence without a language must
#       fail; a skip without a reason must fail; a good one must pass)
set -eu -o pipefail

usage() {
  sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
}

# Splits README into WORK/blocks/NNN.LANG and writes WORK/blocks/index
# (number, README line, language, skip reason) as tab-separated lines.
split_blocks() {
  local readme=$1 out=$2
  mkdir -p "$out"
  awk -v out="$out" '
    function fail(msg) { print FILENAME ":" NR ": " msg > "/dev/stderr"; failed = 1; exit 1 }
    !in_block && /^[ \t]*<!-- readme-test: skip/ {
      reason = $0
      sub(/^[ \t]*<!-- readme-test: skip[ \t]*/, "", reason)
      sub(/[ \t]*-->[ \t]*$/, "", reason)
      if (reason == "") fail("readme-test skip marker without a reason")
      skip = reason; skip_line = NR; next
    }
    !in_block && /^[ \t]*```/ {
      lang = $0
      sub(/^[ \t]*```/, "", lang)
      gsub(/[ \t]/, "", lang)
      if (lang == "") fail("code block without a language (say sh, text, cpp...)")
      if (skip != "" && skip_line != NR - 1) fail("skip marker of line " skip_line " is not right above a block")
      n++
      file = sprintf("%s/%03d.%s", out, n, lang)
      printf "" > file
      printf "%d\t%d\t%s\t%s\n", n, NR, lang, skip > (out "/index")
      skip = ""; in_block = 1; next
    }
    in_block && /^[ \t]*```[ \t]*$/ { in_block = 0; close(file); next }
    in_block { print > file; next }
    skip != "" && skip_line == NR - 1 { fail("skip marker of line " skip_line " is not right above a block") }
    END {
      if (failed) exit 1
      if (in_block) { print FILENAME ": unterminated code block" > "/dev/stderr"; exit 1 }
      if (skip != "") { print FILENAME ":" skip_line ": skip marker without a block" > "/dev/stderr"; exit 1 }
      if (n == 0) printf "" > (out "/index")
    }' "$readme"
}

# Links every top-level entry of the clone into the scratch folder, build/ to the build tree.
make_scratch() {
  local source_dir=$1 build_dir=$2 scratch=$3
  mkdir -p "$scratch"
  local entry name
  for entry in "$source_dir"/* "$source_dir"/.[!.]*; do
    [[ -e $entry ]] || continue
    name=$(basename "$entry")
    [[ $name == .git || $name == build* ]] && continue
    ln -s "$entry" "$scratch/$name"
  done
  ln -s "$build_dir" "$scratch/build"
}

run_readme() {
  local readme=$1 source_dir=$2 build_dir=$3 work=$4
  [[ -f $readme ]] || { echo "no README at $readme" >&2; return 2; }
  rm -rf "$work"
  mkdir -p "$work/tmp"
  split_blocks "$readme" "$work/blocks" || { echo "FAIL: $readme cannot be split into blocks"; return 1; }
  make_scratch "$source_dir" "$build_dir" "$work/scratch"
  export TMPDIR=$work/tmp  # mktemp -d of the README's commands stays in the work folder
  local ran=0 skipped=0 n line lang reason file start
  while IFS=$'\t' read -r n line lang reason; do
    file=$(printf '%s/blocks/%03d.%s' "$work" "$n" "$lang")
    case $lang in
      sh | bash | shell)
        if [[ -n $reason ]]; then
          echo "SKIPPED block $n (README line $line): $reason"
          sed 's/^/    /' "$file"
          skipped=$((skipped + 1))
          continue
        fi
        echo "block $n (README line $line):"
        sed 's/^/    /' "$file"
        start=$SECONDS
        if ! (cd "$work/scratch" && bash -e -o pipefail "$file") </dev/null >"$work/block-$n.log" 2>&1; then
          echo "FAIL: block $n (README line $line) failed; the last lines of its output:"
          tail -n 40 "$work/block-$n.log" | sed 's/^/    /'
          return 1
        fi
        echo "  ok ($((SECONDS - start)) s)"
        ran=$((ran + 1))
        ;;
      ini)
        [[ -z $reason ]] || { echo "FAIL: skip marker on an ini block (line $line)"; return 1; }
        if ! "$build_dir/apps/shape-slam" run --config "$file" --print-config </dev/null \
            >"$work/block-$n.log" 2>&1; then
          echo "FAIL: ini block $n (README line $line) is rejected by shape-slam:"
          sed 's/^/    /' "$work/block-$n.log"
          return 1
        fi
        echo "ini block $n (README line $line): loaded by shape-slam run --config"
        ran=$((ran + 1))
        ;;
      cpp)
        [[ -z $reason ]] || { echo "FAIL: skip marker on a cpp block (line $line)"; return 1; }
        echo "not run here: cpp block $n (README line $line; install_consumer builds and runs it)"
        ;;
      *)
        [[ -z $reason ]] || { echo "FAIL: skip marker on a $lang block (line $line)"; return 1; }
        echo "not run: $lang block $n (README line $line)"
        ;;
    esac
  done <"$work/blocks/index"
  if [[ $ran == 0 ]]; then
    echo "FAIL: no command of $readme was run"
    return 1
  fi
  echo "README commands: $ran blocks ran, $skipped skipped"
}

self_test() {
  local work=$1
  rm -rf "$work"
  mkdir -p "$work/src" "$work/build/apps"
  local fence='```'
  printf '# t\n\n%ssh\ntouch made-by-block-1\n%s\n\n%ssh\ntest -e made-by-block-1\nfalse\necho after\n%s\n' \
    "$fence" "$fence" "$fence" "$fence" >"$work/failing.md"
  printf '%ssh\ntrue\n%s\n%s\nno language\n%s\n' "$fence" "$fence" "$fence" "$fence" >"$work/nolang.md"
  printf '<!-- readme-test: skip -->\n%ssh\ntrue\n%s\n' "$fence" "$fence" >"$work/noreason.md"
  # The first block reads stdin: the blocks after it must still run.
  printf '%ssh\ncat >/dev/null\n%s\n%stext\nnot run\n%s\n<!-- readme-test: skip long -->\n%ssh\nfalse\n%s\n%sbash\ntest -d build\n%s\n' \
    "$fence" "$fence" "$fence" "$fence" "$fence" "$fence" "$fence" "$fence" >"$work/good.md"
  local name
  for name in failing nolang noreason; do
    if run_readme "$work/$name.md" "$work/src" "$work/build" "$work/run-$name" >"$work/$name.log" 2>&1; then
      echo "self-test FAIL: $name.md passed"; cat "$work/$name.log"; return 1
    fi
    echo "self-test: $name.md fails as it should: $(grep -m1 -E 'FAIL|:[0-9]+: ' "$work/$name.log")"
  done
  grep -q "block 2 (README line 7) failed" "$work/failing.log" ||
    { echo "self-test FAIL: the failing block is not named"; cat "$work/failing.log"; return 1; }
  run_readme "$work/good.md" "$work/src" "$work/build" "$work/run-good" >"$work/good.log" 2>&1 ||
    { echo "self-test FAIL: good.md failed"; cat "$work/good.log"; return 1; }
  grep -q "SKIPPED block 3 (README line 8): long" "$work/good.log" ||
    { echo "self-test FAIL: the skipped block is not reported"; cat "$work/good.log"; return 1; }
  grep -q "README commands: 2 blocks ran, 1 skipped" "$work/good.log" ||
    { echo "self-test FAIL: not every block ran"; cat "$work/good.log"; return 1; }
  echo "self-test passed"
}

case ${1:-} in
  -h | --help) usage ;;
  --self-test)
    [[ $# == 2 ]] || { usage >&2; exit 2; }
    self_test "$2"
    ;;
  *)
    [[ $# == 4 ]] || { usage >&2; exit 2; }
    [[ -x $3/apps/shape-slam ]] || { echo "no $3/apps/shape-slam: build it first" >&2; exit 2; }
    run_readme "$1" "$2" "$3" "$4"
    ;;
esac
