#!/bin/sh
# SPDX-License-Identifier: GPL-3.0-or-later
# ecmc's ISO 230-2 input (TGT_DATA[i], REF_DATA_FWD[i,j], REF_DATA_BWD[i,j]) to the CSV that
# ess_iso230_2.json describes, one row per stop in the order the test ran them: per cycle the
# forward pass over the targets, then the backward pass (control.cfg). `seq` stands in for time.
# usage: sh ess_iso230_2_to_csv.sh report.md_ISO230.dat > ess.csv
awk -F'[][=,]' '
  /^TGT_DATA\[/     { t[$2] = $4; if ($2 > n) n = $2 }
  /^REF_DATA_FWD\[/ { f[$2 "," $3] = $5; if ($3 > c) c = $3 }
  /^REF_DATA_BWD\[/ { b[$2 "," $3] = $5 }
  END {
    print "seq,cycle,direction,target_mm,reference_mm"
    s = 0
    for (j = 1; j <= c; ++j) {
      for (i = 1; i <= n; ++i) printf "%d,%d,+,%s,%s\n", s++, j, t[i], f[i "," j]
      for (i = n; i >= 1; --i) printf "%d,%d,-,%s,%s\n", s++, j, t[i], b[i "," j]
    }
  }' "$1"
