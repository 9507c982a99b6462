#!/usr/bin/env bash
# A full disk while a data set is appended: `diffdagger collect` writes to a 256 KiB tmpfs until it
# fills. It must stop with an error that names the file and says the disk is full, leave no partial
# file, and leave the data set readable with every episode it reported.
#
#   tests/full_disk.sh DIFFDAGGER
#
# Mounting needs root, or a user namespace (unshare --user --map-root-user); where neither is
# permitted the test is skipped (exit 77) with a message.
set -u
bin=$(readlink -f "${1:?usage: full_disk.sh DIFFDAGGER}")

if [[ ${DD_FULL_DISK_INSIDE:-} != 1 ]]; then
  # a mount namespace of our own, so the tmpfs disappears with us
  if [[ $(id -u) == 0 ]]; then
    runner=(unshare --mount --propagation private)
  else
    runner=(unshare --user --map-root-user --mount --propagation private)
  fi
  if ! "${runner[@]}" true 2>/dev/null; then
    echo "skipped: this machine permits neither mounting nor a user namespace (${runner[*]} failed)"
    exit 77
  fi
  DD_FULL_DISK_INSIDE=1 exec "${runner[@]}" "$0" "$bin"
fi

dir=$(mktemp -d)
if ! mount -t tmpfs -o size=256k tmpfs "$dir" 2>/dev/null; then
  echo "skipped: mounting a tmpfs is not permitted here"
  rmdir "$dir"
  exit 77
fi
trap 'umount "$dir"; rmdir "$dir"' EXIT
file=$dir/full.hdf5

fail() { echo "FAIL: $*"; exit 1; }
out=$("$bin" --threads 1 collect --task nav2d --episodes 100000 --out "$file" 2>&1)
rc=$?
msg=$(grep '\[E\]' <<<"$out" | tail -1)
echo "collect exited with $rc: $msg"
(( rc != 0 )) || fail "collect filled the disk and still exited 0"
(( rc < 128 )) || fail "collect died of signal $((rc - 128)) after its error (exit $rc)"
[[ $msg == *"$file"* ]] || fail "the error does not name the file"
[[ $msg == *"disk holding it is full"* ]] || fail "the error does not say the disk is full"
[[ ! -e $file.partial ]] || fail "a partial file was left behind"
info=$("$bin" dataset info "$file" 2>&1) || fail "the data set does not read back: $info"
kept=$(sed -n 's/^ *episodes \([0-9]*\) .*/\1/p' <<<"$info")
(( kept > 0 )) || fail "no episode was kept"
# collect's progress line counts the episodes it finished, including the one it could not write
finished=$(grep -o 'collect nav2d ([^)]*) [0-9]*/' <<<"$out" | tail -1 | grep -o '[0-9]*/$' | tr -d /)
echo "the data set reads back with $kept episodes; collect had reported $finished finished"
[[ -z $finished ]] || (( kept >= finished - 1 )) || fail "episodes reported written are missing ($kept of $finished)"
echo "full disk: clear error, no partial file, $kept episodes readable"
