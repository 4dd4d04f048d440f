#!/bin/sh
# Cargo's rustc wrapper for the image (`.cargo/config.toml`, `build.rustc-wrapper`): runs the
# compiler as given ("$1", rustc or clippy's driver), adding `-C symbol-mangling-version=v0`
# for crate `lander` only. Its symbols then name the crate that instantiated them, its copies of
# generic functions from other crates (sorting, iterators, heapless) included, so that
# `linker/g3beige.ld` can place all of crate `lander`'s code in the deferred block by one
# pattern (`.text._R*6lander*`) at opt-level 2, where those copies are its own (without
# share-generics) and a legacy name (`_ZN4core5slice4sort...`) would not say whose they are.
# Every other crate keeps legacy mangling, so no other pattern or symbol lookup changes.
compiler=$1
shift
for arg in "$@"; do
    if [ "$arg" = "lander" ] && [ "${previous:-}" = "--crate-name" ]; then
        exec "$compiler" "$@" -C symbol-mangling-version=v0
    fi
    previous=$arg
done
exec "$compiler" "$@"
