#!/usr/bin/env bash
# Regenerates the before/after figures of docs/identification.md from the
# measured data (DATA_DIR: the full published sets of tests/data/measured/README.md) with tribo-fit and
# analysis/plot_diagnosis.py:
#   analysis/make_docs_figures.sh DATA_DIR [BUILD_DIR]
# DATA_DIR is the directory holding emps/, brfd/ and ratestate/. Files used:
#   emps/emps_train_DATA_EMPS.csv
#   brfd/0.5Hz30lbtension1.5amplitude.csv
#   ratestate/velstep4_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv
#   ratestate/velstep7_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv
#   ratestate/velstep1_TR2_exp013_sepiolite.csv
#   ratestate/velstep2_TR2_exp013_sepiolite.csv
# Writes docs/figures/*.png and keeps each diagnosis (JSON and CSV) in
# build/docs-figures/<case>/.
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:?usage: analysis/make_docs_figures.sh DATA_DIR [BUILD_DIR]}
build=${2:-build}
fit="$build/analysis/tribo-fit"
work="$build/docs-figures"
figures=docs/figures
mkdir -p "$work" "$figures"

run() {  # case title zoom-begin zoom-end -- tribo-fit arguments
  local name=$1 title=$2 z0=$3 z1=$4
  shift 5
  "$fit" diagnose "$@" --out "$work/$name" > "$work/$name.txt"
  /usr/bin/python3 analysis/plot_diagnosis.py "$work/$name" --title "$title" --zoom "$z0" "$z1"
  cp "$work/$name/before_after.png" "$figures/${name}_before_after.png"
  # The signature plots of the accepted effects.
  for effect in $(/usr/bin/python3 -c "import json, sys; print(' '.join(e['name'] for e in json.load(open(sys.argv[1]))['accepted_effects']))" "$work/$name/diagnosis.json"); do
    cp "$work/$name/signature_$effect.png" "$figures/${name}_signature_$effect.png"
  done
  echo "$name: $(grep -E '^(accepted|before|after)' "$work/$name.txt" | cut -c1-140 | tr '\n' ' ')"
}

run emps "EMPS (Janot et al. 2019), training set" 11 13.7 -- \
  "$data/emps/emps_train_DATA_EMPS.csv" --time t_s --position x_m --motor-force force_motor_N \
  --velocity v_derived_m_s --acceleration a_derived_m_s2
run brfd "Banded rotary friction damper (Coble et al. 2022), 0.5 Hz, 1.5 in" 3 7 -- \
  "$data/brfd/0.5Hz30lbtension1.5amplitude.csv" --time t_s --position x_m --force force_friction_N \
  --velocity v_from_x_m_s
cp "$work/brfd/hysteresis.png" "$figures/brfd_hysteresis.png"
run ratestate_basalt "Velocity step 100 -> 300 um/s, basalt (Giacomel et al. 2021)" 11747 11748.5 -- \
  "$data/ratestate/velstep7_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv" --time t_s --position x_m \
  --force shear_stress_Pa --normal normal_stress_eff_Pa --force-unit Pa --smooth 1
run ratestate_basalt_contact "Velocity step 3 -> 10 um/s, basalt (Giacomel et al. 2021), steps as velocity jumps" 11670 11700 -- \
  "$data/ratestate/velstep4_BRAVA_expb819_basalt_Giacomel_et_al_2021.csv" --time t_s --position x_m \
  --force shear_stress_Pa --normal normal_stress_eff_Pa --force-unit Pa --base-model choose --motion-estimator rts_jumps
run ratestate_sepiolite_contact "Velocity step 0.2 -> 2 um/s, sepiolite gouge (Giacomel et al.), contact chosen" 10100 10800 -- \
  "$data/ratestate/velstep1_TR2_exp013_sepiolite.csv" --time t_s --position x_m \
  --force shear_stress_Pa --normal normal_stress_eff_Pa --force-unit Pa --base-model choose
run ratestate_sepiolite "Velocity step, sepiolite gouge (Giacomel et al.)" 11000 13000 -- \
  "$data/ratestate/velstep2_TR2_exp013_sepiolite.csv" --time t_s --position x_m \
  --force shear_stress_Pa --normal normal_stress_eff_Pa --force-unit Pa --smooth 1
