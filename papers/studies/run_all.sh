#!/bin/sh
# Runs every reproduction study into papers/results/<name>.sqlite (resumable).
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
HRAD=${HRAD:-$HERE/../../build/apps/hrad}
cd "$HERE"
for s in ${*:-hanrahan1991 hanrahan1991_linear oracles_all errtime errtime_corridor smits1994 errctl classics classics_steps hemicube hemicube_visibility classics_corridor classics_classroom classics_complexity classics_complexity_cornell classics_gather classics_steps_corridor classics_steps_classroom bases bases_rooms eps_scenes eps_scenes_fine eps_scenes_floor eps_scenes_floor_faces eps_scenes_floor_office oracles_repro oracles_repro_corridor oracles_repro_classroom errctl_level4 error_estimates leaf_budget graz_unreachable reach_rays ff_clusters graz_eps_reflected noise_target graz_eps_reflected_noise eps_smaller}; do
  # Studies of the real scenes in ../shared/scenes (not in the repository)
  # are skipped where that folder is absent.
  if grep -q 'shared/scenes/' $s.toml && [ ! -d ../../../shared/scenes ]; then
    echo "== $s: skipped (../shared/scenes not found next to the repository)"; continue
  fi
  store=../results/$s.sqlite
  # Studies that add points to another study's store.
  case $s in
    eps_scenes_fine) store=../results/eps_scenes.sqlite ;;
    eps_scenes_floor_faces|eps_scenes_floor_office) store=../results/eps_scenes_floor.sqlite ;;
  esac
  resume=; [ -f "$store" ] && resume=--resume
  echo "== $s"; /usr/bin/time -f "$s: %e s wall" "$HRAD" sweep $s.toml --store "$store" $resume --progress
done
