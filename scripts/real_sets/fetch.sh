#!/usr/bin/env bash
# Rebuild the real drone sets of docs/real-sets.md from their public sources.
#
#   scripts/real_sets/fetch.sh OUT_DIR [SET ...]        (default: every set that can be fetched)
#
# Each set lands in OUT_DIR/<set>/{images,labels,manifest.tsv} (YOLO, class 0 = drone), the
# layout `swarmshot gap --real OUT_DIR/<set>` reads. Sources are cloned into OUT_DIR/src/.
#
# Sets:
#   anti-uav-ir  ZhaoJ9014/Anti-UAV (MIT), 117 thermal-IR frames 640x512: 85 JPEG frames of the
#                2019 metric_detector validation set (YOLO labels from val.zip) and 4 frames from
#                each of 8 tracker videos of 2020 (metric_tracker/crops_raw, crop_gt boxes).
#   uavswarm     UAVSwarm/UAVSwarm-dataset (no licence stated; keep it outside the repository),
#                MOT sequences of 3-23 drones: 20 frames from each of 6 test sequences.
#                The clone is about 1.9 GB.
#   uavswarm-topdown  UAVSwarm-02 and UAVSwarm-04 (the UAVSwarm dataset's first two test
#                sequences: one top-down 812x428 camera over fields, 18-20 drones a frame), as
#                copied byte for byte (PNG frames named .jpg, the original gt.txt) into the test
#                fixtures of jeremy-rutman/label_master: 30 frames of each. No licence stated by
#                either repository: keep it outside the repository.
#   mi-drone-yt  pshah2983/Drone-Detection-System (a GitHub copy of the Kaggle "Drone Dataset (UAV)"
#                of Mehdi Ozel, declared MIT by its author): its 46 outdoor frames `yotoNNNNN.jpg`,
#                1280x720 frames of one YouTube review video of a Xiaomi Mi Drone 4K (the drone
#                over lawn, river, trees and a deck, and against overcast sky). The frames are
#                the video's author's: keep them outside the repository.
#   phantom-yt   the same copy: its 43 frames `fotoNNNNN.jpg` of a DJI Phantom 4 flying against
#                blue sky, clouds and palm tops, 1280x720, another YouTube video (same terms).
#   svanstrom-ir  DroneDetectionThesis/Drone-detection-dataset (CC0 1.0; Svanström et al., Data in
#                Brief 2021), its infrared half: 2 frames of each of the 157 IR_DRONE videos
#                (FLIR Breach PTQ-136, 320x256, white-hot, 30 fps; sky, trees, ground, buildings)
#                with the dataset's hand-drawn boxes from IR_DRONE_NNN_LABELS.mat. The labels
#                need `pip install mcos-decoder` (MATLAB groundTruth objects).
#   drone-vs-bird  wosdetc/challenge annotations; the videos are released only on request
#                (data usage agreement, wosdetc@googlegroups.com): put them in $DVB_VIDEOS.
#   nps-drones   mwaseema/Drone-Detection re-annotation of the NPS-Drones clips; the videos are
#                at https://engineering.purdue.edu/~bouman/UAV_Dataset/ : put them in $NPS_VIDEOS.
#
# Offline / tested use: this machine reaches no GitHub, so the script could not be run end to
# end here. For a set whose repository is already on disk, point the script at that git
# directory (a bare snapshot is enough) and no clone is made:
#   ANTI_UAV_GIT_DIR=/work/.mirror/ZhaoJ9014+Anti-UAV/repo scripts/real_sets/fetch.sh /work/realsets anti-uav-ir
# (KAGGLE_UAV_GIT_DIR likewise for mi-drone-yt and phantom-yt, LABEL_MASTER_GIT_DIR for
# uavswarm-topdown, SVANSTROM_GIT_DIR for svanstrom-ir.) That is how /work/realsets/anti-uav-ir,
# mi-drone-yt, phantom-yt, uavswarm-topdown and svanstrom-ir were built (2026, from snapshots
# of the repositories);
# the uavswarm, drone-vs-bird and nps-drones converters were tested on the annotation files
# only (their frames could not be fetched here). Files a snapshot lacks (git objects of 4 MiB
# and more are left out of stored snapshots) are reported and skipped.
#
# Needs: git, python3 (standard library), for video frames an ffmpeg binary ($FFMPEG, PATH,
# or `pip install imageio-ffmpeg`), and for svanstrom-ir `pip install mcos-decoder`.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
to_yolo=(python3 "$here/to_yolo.py")
[ $# -ge 1 ] || { sed -n '2,4p' "$0" >&2; exit 2; }
out="$1"; shift
sets=("$@")
[ ${#sets[@]} -gt 0 ] || sets=(anti-uav-ir mi-drone-yt phantom-yt uavswarm-topdown svanstrom-ir uavswarm)
mkdir -p "$out/src"

# clone URL COMMIT VAR: prints a git dir holding COMMIT (the one named by $VAR when set).
clone() {
  local url="$1" commit="$2" var="$3" dir
  if [ -n "${!var:-}" ]; then dir="${!var}"; else
    dir="$out/src/$(basename "$url").git"
    [ -d "$dir" ] || git clone --bare --quiet "$url" "$dir"
  fi
  git --git-dir="$dir" cat-file -e "$commit^{commit}" || { echo "fetch: $dir lacks commit $commit" >&2; exit 1; }
  echo "$dir"
}

# show GITDIR COMMIT PATH DEST: one file out of the git dir (returns 1 when the blob is absent).
show() {
  mkdir -p "$(dirname "$4")"
  git --git-dir="$1" show "$2:$3" >"$4" 2>/dev/null || { rm -f "$4"; echo "fetch: $3 @ ${2:0:8} not in $1, skipped" >&2; return 1; }
}

fresh() { rm -rf "$out/$1"; mkdir -p "$out/$1"; }

anti_uav_ir() {
  local g; g=$(clone https://github.com/ZhaoJ9014/Anti-UAV eeb82f4e7a2baaece3b187c3140ad394518ca75a ANTI_UAV_GIT_DIR)
  local imgs_at=550f204b188f5e9f26224da4f5929bff93016d13 head=eeb82f4e7a2baaece3b187c3140ad394518ca75a
  local det=Codes/metric_uav/metric_detector/drone_select trk=Codes/metric_uav/metric_tracker
  local tmp="$out/src/anti-uav-ir"; rm -rf "$tmp"; mkdir -p "$tmp/val"
  # The 85 validation JPEGs exist only in the history (later replaced by split zips).
  git --git-dir="$g" ls-tree --name-only "$imgs_at" "$det/images/val/" | grep '\.jpg$' | while read -r p; do
    show "$g" "$imgs_at" "$p" "$tmp/val/$(basename "$p")" || true
  done
  show "$g" "$head" "$det/labels/val/val.zip" "$tmp/val_labels.zip"
  fresh anti-uav-ir
  "${to_yolo[@]}" yolo --images "$tmp/val" --labels "$tmp/val_labels.zip" --out "$out/anti-uav-ir" --prefix antiuav2019_
  for v in 4 5 7 9 18 35 40 41; do
    show "$g" "$head" "$trk/crops_raw/$v.avi" "$tmp/$v.avi" || continue
    show "$g" "$head" "$trk/crop_gt/new_video_${v}_0.txt" "$tmp/gt_$v.txt" || continue
    "${to_yolo[@]}" xywh-video --video "$tmp/$v.avi" --gt "$tmp/gt_$v.txt" --out "$out/anti-uav-ir" \
      --prefix "antiuav2020_v$v" --count 4
  done
  show "$g" "$head" LICENSE "$out/anti-uav-ir/LICENSE" || true
}

# kaggle_frames SET PREFIX NUMBERS...: frames PREFIXnnnnn.jpg (+ .txt) of the Kaggle "Drone
# Dataset (UAV)" copy in pshah2983/Drone-Detection-System, as one set.
kaggle_frames() {
  local set="$1" prefix="$2"; shift 2
  local at=b9b2fa019deec80d5846297c76c7ac3c3f20a7f1
  local g; g=$(clone https://github.com/pshah2983/Drone-Detection-System "$at" KAGGLE_UAV_GIT_DIR)
  local tmp="$out/src/$set"; rm -rf "$tmp"; mkdir -p "$tmp/img"
  for n in "$@"; do
    show "$g" "$at" "drone_dataset_yolo/dataset_txt/$prefix$n.jpg" "$tmp/img/$prefix$n.jpg" || continue
    show "$g" "$at" "drone_dataset_yolo/dataset_txt/$prefix$n.txt" "$tmp/img/$prefix$n.txt" || true
  done
  fresh "$set"
  "${to_yolo[@]}" yolo --images "$tmp/img" --labels "$tmp/img" --out "$out/$set" --prefix "${set//-/}_"
}

# The drone flying outdoors (each video's studio, unboxing and hand-held shots left out), by eye.
mi_drone_yt() {
  kaggle_frames mi-drone-yt yoto 00001 00030 00059 00958 00987 01016 02611 02640 02669 02698 02727 \
    02756 02785 02814 02843 02872 02901 02930 02959 02988 03017 03046 03075 04931 04989 05018 \
    05076 05134 05163 05192 06410 06439 06468 06497 10731 10760 10789 10818 10847 10876 10905 \
    10934 10963 10992 11021 11108
}
phantom_yt() {
  kaggle_frames phantom-yt foto 00204 00233 00262 00291 00320 00349 00378 07338 07367 07396 07425 \
    07454 07483 14356 14385 14414 14443 14472 14501 14530 14559 14588 14617 14646 14675 14704 \
    14733 14762 14791 14820 14849 14878 14907 14936 14965 14994 15023 15052 15081 15110 15139 \
    15400 15429
}

uavswarm() {
  local g; g=$(clone https://github.com/UAVSwarm/UAVSwarm-dataset b639fd03aaad375e88f7907d94b255c910d99415 UAVSWARM_GIT_DIR)
  local at=b639fd03aaad375e88f7907d94b255c910d99415 tmp="$out/src/uavswarm"
  fresh uavswarm; rm -rf "$tmp"
  for s in 02 14 26 38 50 62; do
    local seq="test/UAVSwarm-$s" d="$tmp/UAVSwarm-$s"
    mkdir -p "$d/img1" "$d/gt"
    git --git-dir="$g" archive "$at" "$seq" | tar -x -C "$tmp" --strip-components=1
    "${to_yolo[@]}" mot --seq "$d" --out "$out/uavswarm" --prefix "uavswarm$s" --count 20
  done
}

# The two UAVSwarm test sequences that jeremy-rutman/label_master carries as MOT fixtures
# (tests/fixtures/us7): the whole sequences, frames and gt.txt as in UAVSwarm/UAVSwarm-dataset.
uavswarm_topdown() {
  local at=0156c6b6d8de607a3ff2213e75e044b23c5dc4e7
  local g; g=$(clone https://github.com/jeremy-rutman/label_master "$at" LABEL_MASTER_GIT_DIR)
  local tmp="$out/src/uavswarm-topdown"
  fresh uavswarm-topdown; rm -rf "$tmp"; mkdir -p "$tmp"
  for s in 02 04; do
    local seq="tests/fixtures/us7/UAVSwarm-$s"
    show "$g" "$at" "$seq/gt/gt.txt" "$tmp/UAVSwarm-$s/gt/gt.txt"
    git --git-dir="$g" ls-tree --name-only "$at" "$seq/img1/" | while read -r p; do
      show "$g" "$at" "$p" "$tmp/UAVSwarm-$s/img1/$(basename "$p")" || true
    done
    "${to_yolo[@]}" mot --seq "$tmp/UAVSwarm-$s" --out "$out/uavswarm-topdown" --prefix "uavswarm$s" --count 30
  done
}

# Two frames of each IR_DRONE video, spread evenly over the frames that have a box.
svanstrom_ir() {
  local at=442d0c6750708cc221636f7a1fd31cbd8cb0aeb8
  local g; g=$(clone https://github.com/DroneDetectionThesis/Drone-detection-dataset "$at" SVANSTROM_GIT_DIR)
  local tmp="$out/src/svanstrom-ir"; rm -rf "$tmp"; mkdir -p "$tmp"; fresh svanstrom-ir
  git --git-dir="$g" ls-tree --name-only "$at" Data/Video_IR/ | grep '/IR_DRONE_[0-9]*\.mp4$' | while read -r p; do
    local v; v=$(basename "$p" .mp4)
    show "$g" "$at" "$p" "$tmp/$v.mp4" || continue
    show "$g" "$at" "Data/Video_IR/${v}_LABELS.mat" "$tmp/$v.mat" || continue
    "${to_yolo[@]}" svanstrom --video "$tmp/$v.mp4" --mat "$tmp/$v.mat" --out "$out/svanstrom-ir" \
      --prefix "svir_${v#IR_DRONE_}" --count 2
  done
  show "$g" "$at" LICENSE "$out/svanstrom-ir/LICENSE" || true
}

drone_vs_bird() {
  [ -n "${DVB_VIDEOS:-}" ] || { echo "fetch: drone-vs-bird needs \$DVB_VIDEOS (videos are released on request)" >&2; return 1; }
  local g; g=$(clone https://github.com/wosdetc/challenge b1d64c32776bb12d0c5387f0fd5575adb0c27a73 DVB_GIT_DIR)
  local tmp="$out/src/drone-vs-bird"; mkdir -p "$tmp"; fresh drone-vs-bird
  for v in swarm_dji_phantom dji_phantom_4_hillside_cross dji_mavick_hillside_off_focus dji_matrice_210_hillside \
           two_parrot_disco_1 gopro_001 2019_10_16_C0003_3633_inspire 2019_09_02_C0002_3700_mavic; do
    local video; video=$(ls "$DVB_VIDEOS/$v".* 2>/dev/null | head -n 1 || true)
    [ -n "$video" ] || { echo "fetch: $v.* not in $DVB_VIDEOS, skipped" >&2; continue; }
    show "$g" b1d64c32776bb12d0c5387f0fd5575adb0c27a73 "annotations/$v.txt" "$tmp/$v.txt" || continue
    "${to_yolo[@]}" dvb --video "$video" --ann "$tmp/$v.txt" --out "$out/drone-vs-bird" --prefix "dvb_$v" --count 15
  done
}

nps_drones() {
  [ -n "${NPS_VIDEOS:-}" ] || { echo "fetch: nps-drones needs \$NPS_VIDEOS (https://engineering.purdue.edu/~bouman/UAV_Dataset/)" >&2; return 1; }
  local g; g=$(clone https://github.com/mwaseema/Drone-Detection a4fa41b435ddc6e51f75ec1bb6f034f6cec7fdc0 NPS_GIT_DIR)
  local tmp="$out/src/nps-drones"; mkdir -p "$tmp"; fresh nps-drones
  for c in 001 005 010 015 020 025 030 035 040 045 050; do
    local video; video=$(ls "$NPS_VIDEOS/Clip_$c".* 2>/dev/null | head -n 1 || true)
    [ -n "$video" ] || { echo "fetch: Clip_$c.* not in $NPS_VIDEOS, skipped" >&2; continue; }
    show "$g" a4fa41b435ddc6e51f75ec1bb6f034f6cec7fdc0 "annotations/NPS-Drones-Dataset/Clip_$c.txt" "$tmp/Clip_$c.txt" || continue
    "${to_yolo[@]}" nps --video "$video" --ann "$tmp/Clip_$c.txt" --out "$out/nps-drones" --prefix "nps_clip$c" --count 10
  done
}

for s in "${sets[@]}"; do
  case "$s" in
    anti-uav-ir) anti_uav_ir ;;
    mi-drone-yt) mi_drone_yt ;;
    phantom-yt) phantom_yt ;;
    uavswarm) uavswarm ;;
    uavswarm-topdown) uavswarm_topdown ;;
    svanstrom-ir) svanstrom_ir ;;
    drone-vs-bird) drone_vs_bird ;;
    nps-drones) nps_drones ;;
    *) echo "fetch: unknown set $s (anti-uav-ir, mi-drone-yt, phantom-yt, uavswarm, uavswarm-topdown, svanstrom-ir, drone-vs-bird, nps-drones)" >&2; exit 2 ;;
  esac
done
