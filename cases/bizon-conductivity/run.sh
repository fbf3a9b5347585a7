#!/bin/sh
# Runs every state point of this case, then plots them (plot.py).
#   GRAINBATH=build/grainbath sh cases/bizon-conductivity/run.sh
here=$(cd "$(dirname "$0")" && pwd)
exec sh "$here/../bizon-conductivity/run_states.sh" "$here"
