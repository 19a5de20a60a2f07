# Sourced by bench scripts that drive the burrbench command line: BUILD_DIR from $1
# (default build), the binary built, and a scratch folder removed on exit.
#   build: the build folder; here: bench/; bb: the burrbench binary; work: scratch folder
build=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[1]}")" && pwd)
bb="$build/apps/burrbench"
cmake --build "$build" --target burrbench -j 2 >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
