# Shell functions shared by the SPS benchmark scripts (sps_scaling, sps_sensitivity, sps_table1):
# source this file (it sets here, the script's folder, root, the repository, and the defaults
# sparkdem="", workdir="", csv=$here/results.csv), set the script's own option defaults, then call
# sps_setup.
here=$(cd "$(dirname "${BASH_SOURCE[1]}")" && pwd)
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sparkdem=""
workdir=""
csv="$here/results.csv"

# sps_args "USAGE" "OPTION ..." "FLAG ..." "$@": sets the shell variable of each --OPTION VALUE
# (dashes become underscores) and of each --FLAG (to 1); anything else prints USAGE and exits 2.
sps_args() {
  local usage=$1 options=" $2 " flags=" $3 " key
  shift 3
  while [ $# -gt 0 ]; do
    key=${1#--}
    if [ "$1" != "$key" ] && [[ "$options" == *" $key "* ]] && [ $# -ge 2 ]; then
      printf -v "${key//-/_}" '%s' "$2"; shift 2
    elif [ "$1" != "$key" ] && [[ "$flags" == *" $key "* ]]; then
      printf -v "${key//-/_}" '%s' 1; shift
    else
      echo "usage: $usage" >&2; exit 2
    fi
  done
}

# sps_setup NAME "USAGE" "OPTION ..." "FLAG ..." "$@": sps_args, then checks $sparkdem, makes
# $workdir (a new one under $TMPDIR named NAME.XXXXXX if empty) and prints the load average.
sps_setup() {
  local name=$1
  shift
  sps_args "$@"
  [ -x "$sparkdem" ] || { echo "give --sparkdem PATH (an executable)" >&2; exit 2; }
  [ -n "$workdir" ] || workdir=$(mktemp -d "${TMPDIR:-/tmp}/$name.XXXXXX")
  mkdir -p "$workdir"
  echo "load average: $(cut -d' ' -f1-3 /proc/loadavg); workdir $workdir"
}

# sps_run SCENE DIR: runs SCENE with one thread into DIR/out (DIR made, out replaced), "wall user system" seconds
# in the last line of DIR/time.txt. A failed run is reported, not fatal (the analyzers report it).
sps_run() {
  local rc=0
  mkdir -p "$2"
  rm -rf "$2/out"
  OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE /usr/bin/time -f "%e %U %S" -o "$2/time.txt" \
    "$sparkdem" run "$1" -o "$2/out" --threads 1 --quiet || rc=$?
  [ "$rc" = 0 ] || echo "$(basename "$2"): sparkdem failed (exit $rc)"
  echo "$(basename "$2"): $(tail -n 1 "$2/time.txt" | cut -d' ' -f1) s"
}
