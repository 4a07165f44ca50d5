#!/usr/bin/env bash
# Prints the path of a release binary of COMMIT, building it if needed: a git worktree of
# COMMIT in the cache folder ($MESHRAD_BUILD_CACHE, default ~/.cache/meshrad-build-at),
# `cargo build --release` there (one target folder CACHE/target for every commit, so the
# dependencies build once), the binary copied to CACHE/bin/meshrad-<short sha>; the
# worktree is removed afterwards.
# Anything that is already an executable file (a binary built elsewhere) is printed as is,
# so the scripts beside it take a commit or a binary alike.
# Usage: bash experiments/build-at.sh COMMIT|BINARY   (build output goes to stderr)
set -euo pipefail
[ $# = 1 ] || { echo "usage: build-at.sh COMMIT|BINARY" >&2; exit 2; }
if [ -f "$1" ] && [ -x "$1" ]; then
  (cd "$(dirname "$1")" && echo "$(pwd)/$(basename "$1")")
  exit 0
fi
root=$(cd "$(dirname "$0")/.." && pwd)
sha=$(git -C "$root" rev-parse -q --verify --short "$1^{commit}") || { echo "build-at.sh: $1 is neither a binary nor a commit" >&2; exit 2; }
cache=${MESHRAD_BUILD_CACHE:-$HOME/.cache/meshrad-build-at}
bin=$cache/bin/meshrad-$sha
if [ ! -x "$bin" ]; then
  mkdir -p "$cache/bin"
  wt=$cache/src-$sha
  [ -d "$wt" ] || git -C "$root" worktree add --detach "$wt" "$sha" >&2
  (cd "$wt" && CARGO_TARGET_DIR=$cache/target cargo build --release >&2)
  cp "$cache/target/release/meshrad" "$bin.tmp" && mv "$bin.tmp" "$bin"
  git -C "$root" worktree remove --force "$wt" >&2 || true
fi
echo "$bin"
