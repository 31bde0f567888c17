# Sourced by every launch script right after `set -euo pipefail`, before anything is
# installed, built or run:
#
#   . "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
#
# `--help` (or -h) anywhere among the arguments prints the script's leading comment block,
# its usage, on stdout and exits 0.
answer_help() {
  local script=$1 a
  shift
  for a in "$@"; do
    if [ "$a" = "--help" ] || [ "$a" = "-h" ]; then
      awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$script"
      exit 0
    fi
  done
}
