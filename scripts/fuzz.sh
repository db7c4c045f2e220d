#!/usr/bin/env bash
# Builds the libFuzzer targets of the LAS (and LAZ) reader, the LAZ chunk decoder, the SBET reader,
# the CSV readers, the job-file parser and the correspondence pair files with clang (ASan + UBSan) and runs
# each for a bounded time (default 60 s). Seeds come from ../shared/data when it is there.
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
mountcal_ensure_deps clang libclang-rt-14-dev
seconds="${1:-60}"
out="$root/build-fuzz"
mkdir -p "$out/corpus_las" "$out/corpus_laz" "$out/corpus_sbet" "$out/corpus_csv" "$out/corpus_job" "$out/corpus_pairs"
flags=(-std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined
       -I"$root/include" -I"$root/src" -I/usr/include/eigen3)
jobs="$(nproc)"
# The job parser validates settings through the calibrator's options: it is instrumented, the rest
# of the library comes from the release build (scripts/test.sh builds it; built here if missing).
if [ ! -f "$root/build/src/libmountcal.a" ]; then
  mapfile -t generator < <(mountcal_generator "$root/build")
  cmake -S "$root" -B "$root/build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release > /dev/null
  cmake --build "$root/build" --target mountcal -j "$jobs" > /dev/null
fi
# Every instrumented source compiled once, on every core, then each target linked from its objects.
sources=(tests/fuzz/fuzz_las.cpp tests/fuzz/fuzz_laz.cpp tests/fuzz/fuzz_sbet.cpp tests/fuzz/fuzz_csv.cpp
         tests/fuzz/fuzz_job.cpp tests/fuzz/fuzz_pairs.cpp src/report/swath_qc.cpp src/io/las.cpp src/io/las_crs.cpp src/io/laz.cpp src/io/laz_coder.cpp
         src/io/laz_items.cpp src/io/sbet.cpp src/io/csv.cpp src/io/atomic_file.cpp src/core/geodesy.cpp
         src/core/trajectory.cpp src/core/sensor_model.cpp src/core/error.cpp src/job/schema.cpp
         src/methods/correspondence/pair_file.cpp)
for s in "${sources[@]}"; do mkdir -p "$out/obj/$(dirname "$s")"; done
printf '%s\n' "${sources[@]}" | xargs -P "$jobs" -I{} clang++ "${flags[@]}" -c "$root/{}" -o "$out/obj/{}.o"
o() { for s in "$@"; do printf '%s\n' "$out/obj/$s.o"; done; }
mapfile -t laz < <(o src/io/laz.cpp src/io/laz_coder.cpp src/io/laz_items.cpp src/core/error.cpp)
mapfile -t nav < <(o src/io/sbet.cpp src/io/csv.cpp src/io/atomic_file.cpp src/core/geodesy.cpp src/core/trajectory.cpp src/core/error.cpp)
release=("$root/build/src/libmountcal.a" "$root/build/src/libmountcal_core.a" -lceres -lglog -lflann_cpp -llz4 -lOpenMeshCore -lproj
         -lpthread -fopenmp)
clang++ "${flags[@]}" -o "$out/fuzz_las" $(o tests/fuzz/fuzz_las.cpp src/io/las.cpp src/io/las_crs.cpp) "${laz[@]}" -lproj -lpthread
clang++ "${flags[@]}" -o "$out/fuzz_laz" $(o tests/fuzz/fuzz_laz.cpp) "${laz[@]}"
clang++ "${flags[@]}" -o "$out/fuzz_sbet" $(o tests/fuzz/fuzz_sbet.cpp) "${nav[@]}"
clang++ "${flags[@]}" -o "$out/fuzz_csv" $(o tests/fuzz/fuzz_csv.cpp src/core/sensor_model.cpp) "${nav[@]}"
clang++ "${flags[@]}" -o "$out/fuzz_job" $(o tests/fuzz/fuzz_job.cpp src/job/schema.cpp src/report/swath_qc.cpp) "${release[@]}"
# The correspondence pair file reader, instrumented; the options' checks from the release library.
clang++ "${flags[@]}" -o "$out/fuzz_pairs" $(o tests/fuzz/fuzz_pairs.cpp src/methods/correspondence/pair_file.cpp) "${release[@]}"
# Its seed: a small pair file written here byte by byte (README "Correspondence pair files").
python3 - "$out/corpus_pairs/seed.mcpair" <<'PY'
import struct, sys
b = b"MCPAIRS2" + struct.pack("<I", 1)
for s in (b"ew1", b"ns2"):
    b += struct.pack("<I", len(s)) + s
b += struct.pack("<3d", 1.6, 0.6, 0.65) + struct.pack("<QI", 1200, 3)
b += struct.pack("<4d2i", 1.0, 0.0, 0.0, 0.0, 8, 16) + struct.pack("<6d", 0, 0, 0, 0, 0, 0)
point = lambda i, t: struct.pack("<Qd3d3d", i, t, 10.0 + i, 20.0, 1.5, 0.0, 30.0, -300.0)
b += struct.pack("<Q", 1) + point(5, 100.25) + struct.pack("<4d", 0.0, 0.0, 1.0, 0.7)
b += struct.pack("<Q", 2) + point(7, 130.5) + point(9, 130.75) + b"MCPAIREN"
open(sys.argv[1], "wb").write(b)
PY
data="$root/../shared/data"
if [ -d "$data" ]; then
  cp -f "$data/leeward/points.las" "$out/corpus_las/" 2>/dev/null || true
  # Whole small LAZ files for the reader; their first chunks, behind the selector bytes, for the
  # chunk decoder (format 3 v2 and v1, format 0, format 6, format 7 from the COPC file).
  for f in simple.laz point10.las.laz 1_4_w_evlr.laz 1.2-with-color.copc.laz no-points-1.3.laz; do
    cp -f "$data/laz/$f" "$out/corpus_las/" 2>/dev/null || true
  done
  chunk_seed() {  # FILE SELECTOR-BYTES SKIP-AFTER-OFFSET NAME
    local off
    off=$(od -An -tu4 -j96 -N4 "$data/laz/$1" | tr -d ' ')
    { printf "$2"; dd if="$data/laz/$1" bs=1 skip=$((off + $3)) count=16384 2>/dev/null; } > "$out/corpus_laz/$4"
  }
  chunk_seed simple.laz '\x03\x00\x28\x04' 8 simple || true
  chunk_seed simple-laszip-compressor-version-1.2r0.laz '\x0b\x00\x28\x04' 0 simple_v1 || true
  chunk_seed point10.las.laz '\x00\x00\x28\x04' 8 point10 || true
  chunk_seed 1_4_w_evlr.laz '\x04\x00\xe7\x03' 8 format6 || true
  chunk_seed 1.2-with-color.copc.laz '\x05\x00\x00\x00' 8 format7 || true
  cp -f "$data/pdal/2-points.sbet" "$data/pdal/badfile.sbet" "$data/leeward/sbet.out" "$out/corpus_sbet/" 2>/dev/null || true
else
  echo "fuzz: ../shared/data not found; starting from empty corpora"
fi
# CSV seeds: a few lines of each kind behind the reader-selector byte (written here, no data needed).
printf '\x08tie_id,strip_id,x,y\na,1,0.5,2\na,2,0.6,2.1\n' > "$out/corpus_csv/ties"
printf '\x01time,x,y,z,roll_deg,pitch_deg,heading_deg\n1,0,0,100,0.1,0.2,90\n2,50,0,100,0.1,0.2,90\n' > "$out/corpus_csv/trajectory"
printf '\x02gcp_id,x,y,z,sigma_xy_m,sigma_z_m\ng1,1,2,3,0.02,0.03\n' > "$out/corpus_csv/gcps"
printf '\x03plane_id,xmin,ymin,xmax,ymax\np,0,0,10,10\n' > "$out/corpus_csv/planes"
printf '\x04time,scan_angle_deg,range_m,intensity\n1.5,10,800,40\n' > "$out/corpus_csv/raw_line"
printf '\x05time,laser_id,azimuth_deg,range_m,intensity\n1.5,3,10,40,7\n' > "$out/corpus_csv/raw_multibeam"
printf '\x06time,xs,ys,zs,intensity\n1.5,1,2,30,7\n' > "$out/corpus_csv/raw_vector"
printf '\x07time,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,heading_deg\n1,34,-118,100,0,0,0\n2,34.0001,-118,100,0,0,0\n' > "$out/corpus_csv/geodetic"
# Job seeds: SPEC §4's example and the committed gravity jobs (geodetic frame, pose fields, LAZ).
printf '{"frame":{"type":"local"},"trajectory":{"path":"trajectory.csv","format":"csv","time_offset_s":0.0},"sensor":{"type":"line","nominal_rotation_deg":[0,0,0]},"mounting_used":{"lever_arm_m":[0,0,0],"boresight_deg":[0,0,0]},"strips":[{"id":"1","path":"strip1.las"},{"id":"2","path":"strip2.las"}],"ties":"ties.csv","method":"vtpm","estimate":{"lever_arm":[true,true,false],"boresight":[true,true,true]},"vtpm":{"radius_m":1.0,"ransac_threshold_m":0.05},"solver":{"max_iterations":100,"loss":"trivial"},"output":{"result":"result.json","report":"report.html"}}\n' > "$out/corpus_job/spec"
cp -f "$root"/examples/gravity/*.json "$out/corpus_job/"
# A swath QC file (docs/swath-qc.md: qc.json) of one pair, for the QC reader in the same target.
printf '{"cell_size_m":5,"plane_cell_size_m":2.5,"pairs":[{"a":"1","b":"2","before":{"cells":3,"rmsdz_m":0.2,"mean_dz_m":0.1,"max_abs_dz_m":0.3,"share_over":[{"threshold_m":0.04,"share":1}]},"after":{"cells":4,"rmsdz_m":0.01,"mean_dz_m":0,"max_abs_dz_m":0.02,"share_over":[{"threshold_m":0.04,"share":0}]},"point_to_plane":{"before":{"queries":9,"used":8,"median_m":0.1,"rms_m":0.2,"p90_m":0.3},"after":{"queries":9,"used":8,"median_m":0.01,"rms_m":0.02,"p90_m":0.03}},"sloped_planes":{"before":{"cells":0,"rms_m":null,"mean_m":null,"max_abs_m":null},"after":{"cells":2,"rms_m":0.01,"mean_m":0,"max_abs_m":0.01}},"roof_edges":{"before":{"cells":1,"rms_m":0.3,"mean_m":0.3,"max_abs_m":0.3},"after":{"cells":1,"rms_m":0.01,"mean_m":0.01,"max_abs_m":0.01}}}],"strips":[{"id":"1","smooth_cells":5,"intraswath_precision_m":0.02,"intraswath_max_m":0.07}],"summary":{"share_over":[{"threshold_m":0.04,"share":0}]}}\n' > "$out/corpus_job/qc"
# One fuzzer per core at a time; each one's statistics (or its failure) printed when it ends.
fuzz() {
  "$out/fuzz_$1" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$out/" "$out/corpus_$1" > "$out/fuzz_$1.log" 2>&1
}
targets=(las laz sbet csv job pairs)
for ((i = 0; i < ${#targets[@]}; i += jobs)); do
  pids=()
  for t in "${targets[@]:i:jobs}"; do
    echo "fuzz: $t for ${seconds} s"
    fuzz "$t" &
    pids+=($!)
  done
  k=0
  for t in "${targets[@]:i:jobs}"; do
    wait "${pids[k]}" || { tail -40 "$out/fuzz_$t.log"; echo "fuzz: $t FAILED"; exit 1; }
    grep -E "stat::number_of_executed_units|Done" "$out/fuzz_$t.log" | tail -2
    k=$((k + 1))
  done
done
echo "fuzz: no crash, no sanitizer report"
