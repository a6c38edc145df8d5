#!/bin/bash
# launch-prefix helper of replay_bag.test: wait (at most 120 s) until the file $1 exists, then run
# the rest of the command line (rosbag play ...).
file="$1"; shift
for _ in $(seq 1200); do
  if [ -e "$file" ]; then exec "$@"; fi
  sleep 0.1
done
echo "wait_for_file.sh: $file did not appear within 120 s" >&2
exit 1
