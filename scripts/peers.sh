#!/bin/bash
# glint beside its peers, one script, one machine, one run (BENCHMARKS.md §1, §1.1, §2.1, §3, §6.4).
#
# Usage: bash scripts/peers.sh [quick]   (after cargo build --release; peers installed as below)
#   quick: tiny sizes and one round (a smoke test: every block should print numbers in seconds)
#   (none): the full battery at the sizes of BENCHMARKS.md (about 4 minutes on the 2-core EPYC; §13)
# Environment: GLINT (default target/release/glint of this repo), GLINT_MAIN (default this repo:
#   scenes/), GLINT_SHARED (default ../shared beside the repo), ROUNDS (override the number of interleaved rounds),
#   DRJIT_LIBLLVM_PATH (default Debian libllvm19's .so; LLVM 15 makes drjit 1.5.0 abort),
#   BLOCKS (default "a b c d": run only some blocks, e.g. BLOCKS="c d").
# Peers: povray (Debian povray 3.7), viewer_stream (Debian embree-tools, Embree 3.13.5),
#   ../shared/bench/embree3_rays.sh (Debian libembree-dev + g++), Mitsuba 3 llvm_ad_rgb
#   (pip mitsuba; timed by mitsuba_cbox_time.py beside this script).
# Every block survives a failing step: it prints "ERROR: ..." with the tail of that step's log and
# goes on. Logs of every step stay in $OUT (printed at the start).
set -u

MODE=${1:-full}
case "$MODE" in quick | full) ;; *) echo "usage: $0 [quick]" >&2; exit 2 ;; esac
HERE=$(cd "$(dirname "$0")" && pwd)
MAIN=${GLINT_MAIN:-$(dirname "$HERE")}
GLINT=${GLINT:-$MAIN/target/release/glint}
SHARED=${GLINT_SHARED:-$(dirname "$MAIN")/shared}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
BLOCKS=${BLOCKS:-a b c d}
OUT=$(mktemp -d /tmp/peers.XXXXXX)
DRAGON=$SHARED/data/meshes/stanford_dragon_100k.ply
SPONZA_OBJ=$SHARED/data/scenes/sponza_dabrovic/sponza.obj
CBOX_XML=$SHARED/data/mitsuba/scenes/cbox/cbox.xml

if [ "$MODE" = quick ]; then
  ROUNDS=${ROUNDS:-1}
  POV_W=320 POV_H=180 POV_PAIRS=1
  VS_W=256 VS_H=192 VS_BENCH="1 3" GW_FRAMES=3
  RAY_W=256 RAY_H=192 RAY_REPS=2 BUILDS=2
  MI_RES=64 MI_SPP=4 MI_FRAMES=2
else
  ROUNDS=${ROUNDS:-3}
  POV_W=1920 POV_H=1080 POV_PAIRS=3
  VS_W=1024 VS_H=768 VS_BENCH="3 20" GW_FRAMES=20
  RAY_W=1024 RAY_H=768 RAY_REPS=7 BUILDS=7
  MI_RES=256 MI_SPP=16 MI_FRAMES=5
fi

# ---------------------------------------------------------------------------------------------
# helpers
# median of the numbers given as arguments (empty: "nan")
med() { printf '%s\n' "$@" | grep -E '^[0-9.eE+-]+$' | sort -g |
  awk '{v[NR]=$1} END{if(NR==0){print "nan"} else if(NR%2){print v[(NR+1)/2]} else {printf "%.4g\n",(v[NR/2]+v[NR/2+1])/2}}'; }
# a / b with 3 decimals (nan when either is missing or b is 0)
ratio() { awk -v a="${1:-}" -v b="${2:-}" 'BEGIN{if(a==""||b==""||a=="nan"||b=="nan"||b+0==0){print "nan"} else printf "%.3f\n", a/b}'; }
# run a step, output to a log; on failure print ERROR and the log's tail (to stderr, so that a
# captured result stays clean); returns the status
step() { # step LOGNAME CMD...
  local log=$OUT/$1; shift
  "$@" >"$log" 2>&1
  local rc=$?
  if [ $rc -ne 0 ]; then
    { echo "ERROR: '$*' exited $rc; last lines of $log:"; tail -n 5 "$log" | sed 's/^/    /'; } >&2
  fi
  return $rc
}
# whole-process wall time in seconds (3 decimals) of a step; prints the time, or nothing on failure
wall() { # wall LOGNAME CMD...
  local t0 t1
  t0=$(date +%s%N)
  step "$@" || return 1
  t1=$(date +%s%N)
  awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.3f\n", (b-a)/1e9}'
}
need() { # need CMD...: all on PATH or executable, else ERROR
  local c ok=0
  for c in "$@"; do
    if ! command -v "$c" >/dev/null 2>&1; then echo "ERROR: '$c' not found"; ok=1; fi
  done
  return $ok
}
load() { awk '{print "load " $1 " " $2 " " $3}' /proc/loadavg; }
header() { echo; echo "=== $* ==="; load; }

echo "peers: mode=$MODE rounds=$ROUNDS glint=$GLINT ($("$GLINT" --version 2>&1 | head -1)) logs=$OUT"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), avx512f: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no); $(date -u '+%Y-%m-%d %H:%M UTC')"

# ---------------------------------------------------------------------------------------------
block_a() {
  header "a. POV-Ray 3.7 vs glint render: Whitted benchmark scene ${POV_W}x${POV_H}, whole process wall s, $POV_PAIRS interleaved pair(s) (BENCHMARKS.md §3.2)"
  need povray "$GLINT" || return
  echo "povray: $(povray --version 2>&1 | grep -m1 'POV-Ray')"
  local i tp tg pov=() gl=() rat=()
  for i in $(seq 1 "$POV_PAIRS"); do
    tp=$(wall a_pov_$i.log povray +I"$SHARED/bench/whitted.pov" +O"$OUT/pov.png" +W$POV_W +H$POV_H -A +WT2 -D)
    tg=$(cd "$MAIN" && wall a_glint_$i.log "$GLINT" render "$MAIN/scenes/whitted-bench.toml" --width $POV_W --height $POV_H --threads 2 -o "$OUT/g.png")
    echo "pair $i: povray ${tp:-failed} s, glint ${tg:-failed} s ($(grep -m1 '^glint:' "$OUT/a_glint_$i.log" 2>/dev/null | sed 's/ -> .*//'))"
    [ -n "$tp" ] && pov+=("$tp")
    [ -n "$tg" ] && gl+=("$tg")
    [ -n "$tp" ] && [ -n "$tg" ] && rat+=("$(ratio "$tp" "$tg")")
  done
  local mp mg
  mp=$(med "${pov[@]}") mg=$(med "${gl[@]}")
  echo "RESULT a: povray median ${mp} s, glint median ${mg} s, povray/glint = $(ratio "$mp" "$mg")x (median of per-pair ratios $(med "${rat[@]}")x; target >= 20x)"
}

# ---------------------------------------------------------------------------------------------
block_b() {
  header "b. Embree viewer_stream vs glint bench whitted: Sponza ${VS_W}x${VS_H}, 2 threads, $ROUNDS interleaved rounds (issue 15, BENCHMARKS.md §3.3)"
  need viewer_stream "$GLINT" || return
  local vs_args=(-i "$SPONZA_OBJ" --vp -13 2.2 -0.6 --vi 8 5.5 0.6 --vu 0 1 0 --fov 55.4 --size $VS_W $VS_H --threads 2)
  # which ISA Embree dispatches to here (a tiny separate run, verbose)
  if step b_isa.log viewer_stream "${vs_args[@]}" --size 64 64 --benchmark 0 1 --rtcore verbose=2; then
    echo "embree: $(grep -m1 'Embree Ray Tracing Kernels' "$OUT/b_isa.log" | sed 's/^ *//'); $(grep -m1 'intersector1 ' "$OUT/b_isa.log" | sed 's/^ *//')"
  fi
  local r vfps=() vmr=() v2fps=() v2mr=() gfps=() gmr=() gms=() line
  for r in $(seq 1 "$ROUNDS"); do
    if (cd "$MAIN" && step b_vs_$r.log viewer_stream "${vs_args[@]}" --benchmark $VS_BENCH); then
      vfps+=("$(awk '/^BENCHMARK_RENDER_AVG /{print $2}' "$OUT/b_vs_$r.log")")
      vmr+=("$(awk '/^BENCHMARK_RENDER_MRAYPS_AVG /{print $2}' "$OUT/b_vs_$r.log")")
      echo "round $r: viewer_stream (default ISA) ${vfps[-1]} fps, ${vmr[-1]} Mrays/s (primary rays only, eye-light shading)"
    fi
    if (cd "$MAIN" && step b_vs2_$r.log viewer_stream "${vs_args[@]}" --benchmark $VS_BENCH --isa avx2); then
      v2fps+=("$(awk '/^BENCHMARK_RENDER_AVG /{print $2}' "$OUT/b_vs2_$r.log")")
      v2mr+=("$(awk '/^BENCHMARK_RENDER_MRAYPS_AVG /{print $2}' "$OUT/b_vs2_$r.log")")
      echo "round $r: viewer_stream --isa avx2 ${v2fps[-1]} fps, ${v2mr[-1]} Mrays/s"
    fi
    if (cd "$MAIN" && step b_glint_$r.log "$GLINT" bench whitted --scene scenes/sponza.toml --width $VS_W --height $VS_H --threads 2 --frames $GW_FRAMES); then
      line=$(grep -m1 '^whitted ' "$OUT/b_glint_$r.log")
      gms+=("$(sed -n 's/.*median \([0-9.]*\) ms\/frame.*/\1/p' <<<"$line")")
      gfps+=("$(sed -n 's/.*ms\/frame (\([0-9.]*\) fps).*/\1/p' <<<"$line")")
      gmr+=("$(sed -n 's/.*fps), \([0-9.]*\) Mrays\/s.*/\1/p' <<<"$line")")
      echo "round $r: glint ${gms[-1]} ms/frame, ${gfps[-1]} fps, ${gmr[-1]} Mrays/s ($(sed -n 's/.*Mrays\/s, \([0-9]*\) rays\/frame.*/\1/p' <<<"$line") primary+shadow rays/frame)"
    fi
  done
  local mv mg
  mv=$(med "${vmr[@]}") mg=$(med "${gmr[@]}")
  echo "RESULT b: viewer_stream $(med "${vfps[@]}") fps, $mv Mrays/s (--isa avx2: $(med "${v2fps[@]}") fps, $(med "${v2mr[@]}") Mrays/s); glint $(med "${gfps[@]}") fps ($(med "${gms[@]}") ms), $mg Mrays/s; glint/Embree Mrays/s = $(ratio "$mg" "$mv")x (target >= 1)"
}

# ---------------------------------------------------------------------------------------------
# embree_best LOG KIND: the best Mrays/s of the APIs BENCHMARKS.md compares for that kind
embree_api() { awk -v api="$2" '$1=="embree3" && $2==api {sub("Mrays_per_s_median=","",$4); print $4}' "$1"; }
embree_best() {
  if [ "$2" = shadow ]; then embree_api "$1" rtcOccluded1
  else printf '%s\n' "$(embree_api "$1" rtcIntersect1)" "$(embree_api "$1" rtcIntersect8)" "$(embree_api "$1" rtcIntersect1M)" | sort -g | tail -1; fi
}
block_c() {
  header "c. Embree 3 native vs glint bench rays: dragon 100k, ${RAY_W}x${RAY_H} rays, reps $RAY_REPS, $ROUNDS rounds (BENCHMARKS.md §1, §1.1); builds $BUILDS (§2.1)"
  need g++ "$GLINT" || return
  [ -f "$DRAGON" ] || { echo "ERROR: $DRAGON missing"; return; }
  local kind t r d occ g e gs es rs summary=()
  for kind in primary diffuse shadow; do
    for t in 1 2; do
      gs=() es=() rs=()
      occ=()
      [ "$kind" = shadow ] && occ=(--occluded)
      for r in $(seq 1 "$ROUNDS"); do
        d=$OUT/d_${kind}_$t
        step c_glint_${kind}_${t}_$r.log "$GLINT" bench rays --scene "$DRAGON" --kind $kind --threads $t --reps $RAY_REPS --width $RAY_W --height $RAY_H --dump "$d" || continue
        g=$(sed -n 's/^mrays_per_s_median=//p' "$OUT/c_glint_${kind}_${t}_$r.log")
        step c_embree_${kind}_${t}_$r.log "$SHARED/bench/embree3_rays.sh" "$d" $t $RAY_REPS "${occ[@]}" || { rm -f "$d".*; continue; }
        e=$(embree_best "$OUT/c_embree_${kind}_${t}_$r.log" $kind)
        echo "$kind t=$t round $r: glint $g Mrays/s; Embree $(for api in rtcIntersect1 rtcIntersect8 rtcIntersect1M rtcOccluded1; do printf '%s %s  ' ${api#rtc} "$(embree_api "$OUT/c_embree_${kind}_${t}_$r.log" $api)"; done)-> best $e; $(grep -m1 '^agreement' "$OUT/c_embree_${kind}_${t}_$r.log" | cut -d: -f1)"
        gs+=("$g") es+=("$e") rs+=("$(ratio "$g" "$e")")
        rm -f "$d".*
      done
      summary+=("$(printf '%-8s %d | %8s | %8s | %6s' $kind $t "$(med "${gs[@]}")" "$(med "${es[@]}")" "$(med "${rs[@]}")")")
    done
  done
  echo "RESULT c (medians over rounds; ratio = median of per-round glint/Embree-best; best = max(Intersect1, Intersect8, Intersect1M), shadow: Occluded1):"
  echo "kind   threads | glint Mr/s | Embree best | glint/best"
  printf '%s\n' "${summary[@]}"
  # BVH build, §2.1: both sides a median of $BUILDS builds in one process
  local gb eb bsum=()
  for t in 1 2; do
    gs=() es=()
    for r in $(seq 1 "$ROUNDS"); do
      d=$OUT/b_${t}
      step c_build_glint_${t}_$r.log "$GLINT" bench rays --scene "$DRAGON" --kind shadow --threads $t --reps 1 --builds $BUILDS --width $RAY_W --height $RAY_H --dump "$d" || continue
      gb=$(sed -n 's/.*build median \([0-9.]*\) ms.*/\1/p' "$OUT/c_build_glint_${t}_$r.log")
      step c_build_embree_${t}_$r.log "$SHARED/bench/embree3_rays.sh" "$d" $t $BUILDS --occluded || { rm -f "$d".*; continue; }
      eb=$(sed -n 's/.*build_ms_median=\([0-9.]*\).*/\1/p' "$OUT/c_build_embree_${t}_$r.log")
      echo "build t=$t round $r: glint median $gb ms, Embree median $eb ms"
      gs+=("$gb") es+=("$eb")
      rm -f "$d".*
    done
    bsum+=("build dragon 100k, $t thread(s): glint $(med "${gs[@]}") ms, Embree $(med "${es[@]}") ms, glint/Embree $(ratio "$(med "${gs[@]}")" "$(med "${es[@]}")")x")
  done
  printf 'RESULT c: %s\n' "${bsum[@]}"
}

# ---------------------------------------------------------------------------------------------
block_d() {
  header "d. Mitsuba 3 llvm_ad_rgb vs glint bench path: Mitsuba's cbox ${MI_RES}x${MI_RES}, $MI_SPP spp, 2 threads, unfiltered, $ROUNDS interleaved rounds (BENCHMARKS.md §6.4)"
  need python3 "$GLINT" || return
  echo "DRJIT_LIBLLVM_PATH=$DRJIT_LIBLLVM_PATH"
  local r m=() m6=() g=() g64=() v
  for r in $(seq 1 "$ROUNDS"); do
    if step d_mi_$r.log python3 "$HERE/mitsuba_cbox_time.py" --variant llvm_ad_rgb --res $MI_RES --spp $MI_SPP --frames $MI_FRAMES --threads 2 --max-depth -1 --scene "$CBOX_XML"; then
      v=$(sed -n 's/^mpaths_per_s_median=//p' "$OUT/d_mi_$r.log"); m+=("$v")
      echo "round $r: mitsuba max_depth -1: $v M paths/s  [$(grep -m1 '^mitsuba ' "$OUT/d_mi_$r.log")]"
    fi
    if (cd "$MAIN" && step d_glint_$r.log "$GLINT" bench path scenes/mitsuba-cbox.toml --width $MI_RES --height $MI_RES --spp $MI_SPP --frames $MI_FRAMES --threads 2); then
      v=$(sed -n 's/^mpaths_per_s_median=//p' "$OUT/d_glint_$r.log"); g+=("$v")
      echo "round $r: glint (scene's 4 bounces = Mitsuba max_depth 6, as §6.4): $v M paths/s  [$(grep -m1 '^path ' "$OUT/d_glint_$r.log")]"
    fi
    if step d_mi6_$r.log python3 "$HERE/mitsuba_cbox_time.py" --variant llvm_ad_rgb --res $MI_RES --spp $MI_SPP --frames $MI_FRAMES --threads 2 --max-depth 6 --scene "$CBOX_XML"; then
      v=$(sed -n 's/^mpaths_per_s_median=//p' "$OUT/d_mi6_$r.log"); m6+=("$v")
      echo "round $r: mitsuba max_depth 6: $v M paths/s"
    fi
    if (cd "$MAIN" && step d_glint64_$r.log "$GLINT" bench path scenes/mitsuba-cbox.toml --width $MI_RES --height $MI_RES --spp $MI_SPP --frames $MI_FRAMES --threads 2 --max-bounces 64); then
      v=$(sed -n 's/^mpaths_per_s_median=//p' "$OUT/d_glint64_$r.log"); g64+=("$v")
      echo "round $r: glint --max-bounces 64 (its cap; Russian roulette ends paths): $v M paths/s"
    fi
  done
  local mm mg
  mm=$(med "${m[@]}") mg=$(med "${g[@]}")
  echo "RESULT d: Mitsuba llvm_ad_rgb $mm M paths/s (max_depth 6: $(med "${m6[@]}")); glint $mg M paths/s (--max-bounces 64: $(med "${g64[@]}")); glint/Mitsuba = $(ratio "$mg" "$mm")x (target >= 1.5x)"
}

T0=$(date +%s)
for b in $BLOCKS; do
  case "$b" in
    a) block_a ;; b) block_b ;; c) block_c ;; d) block_d ;;
    *) echo "unknown block '$b'" ;;
  esac
done
echo
echo "peers: done in $(($(date +%s) - T0)) s; logs in $OUT"
