#!/bin/sh
# Run a command near the wall time it has on an idle machine, while other sessions keep the
# cores busy: in its own session, hence its own scheduler autogroup
# (/proc/sys/kernel/sched_autogroup_enabled = 1), at autogroup nice -20 (needs root). The
# command and its threads then get almost all of both cores for its few seconds. Made for
# BENCHMARKS.md's wall-time ratios on the shared 2-core machine, e.g.
#
#   /usr/bin/time -f '%e s %U u %S s %M KB' scripts/idle_wall.sh skylod lod IN.gml --pois P.csv -o OUT.gml
#
# Nice inside one autogroup (plain `nice -n -20`) does not help: autogroups share the CPU
# equally whatever their tasks' nice values.
[ $# -ge 1 ] || { sed -n '2,9p' "$0" >&2; exit 2; }
exec setsid sh -c 'echo -20 > /proc/$$/autogroup && exec "$@"' sh "$@"
