# Sourced by the scripts that install Debian packages they need (build_tools.sh, test_slurm.sh).
# apt_install WHY PACKAGE...: installs the packages with apt-get when we are root or sudo works
# without a password; otherwise stops with the exact command to run.
apt_install() {
  local why=$1; shift
  echo "$why: missing $*" >&2
  if ! command -v apt-get >/dev/null; then
    echo "error: no apt-get here: install $* with your package manager, then run make again" >&2
    exit 1
  fi
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
      sudo=(sudo -n)
    else
      echo "error: installing them needs root; run this, then make again:" >&2
      echo "  sudo apt-get update && sudo apt-get install -y --no-install-recommends $*" >&2
      exit 1
    fi
  fi
  echo "$why: installing $* with apt-get" >&2
  "${sudo[@]}" apt-get update -q >&2
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -q --no-install-recommends "$@" >&2
}
