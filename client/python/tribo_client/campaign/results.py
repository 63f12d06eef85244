"""The results table of a campaign: one row per finished run, rebuilt from the
run folders (OUT/runs/*/result.json), ordered by run index. Written as CSV
and as HDF5 (h5py: Debian 12 ships no pytables for pandas' HDF5 writer, and
no Parquet): group /runs with one dataset per column, the campaign's name,
spec and software versions as attributes."""

import glob
import json
import os

import numpy as np

# Units of the table's columns (SI; HDF5 attribute "unit" on each dataset).
COLUMN_UNITS = {
    "seed": "", "samples": "", "simulated_s": "s", "sim_wall_s": "s", "wall_s": "s", "cpu_s": "s",
    "diagnosis_wall_s": "s", "mu_mean": "", "friction_mean_n": "N", "stiction_peak_mean_n": "N",
    "drift_mean_rate_n_per_s": "N/s", "tilt_slope": "", "heldout_rms_before": "N", "heldout_rms_after": "N",
    "scorecard_rows": "", "scorecard_goals": "", "scorecard_within_goal": "", "scorecard_wall_s": "s",
}


def load_rows(out_dir):
    rows = []
    for path in glob.glob(os.path.join(out_dir, "runs", "*", "result.json")):
        with open(path, encoding="utf-8") as f:
            rows.append(json.load(f)["row"])
    rows.sort(key=lambda r: r["index"])
    return rows


def results_frame(out_dir):
    import pandas as pd
    rows = load_rows(out_dir)
    frame = pd.DataFrame(rows)
    if "index" in frame:
        frame = frame.set_index("index", drop=False)
        frame.index.name = None
    return frame


# The files a campaign writes from its run folders. A campaign that ends
# with runs left (--limit, runs lost) writes them as NAME.partial.EXT
# instead, so that the complete campaign's files are never replaced by a
# part of it; a complete campaign removes the partial ones.
OUTPUT_FILES = ("results.csv", "results.h5", "reliability.csv", "confusion.csv", "confusion.png", "scorecard.csv",
                "scorecard_sweep.png")
PARTIAL = ".partial"


def output_path(out_dir, filename, partial=False):
    """OUT/filename, or OUT/stem.partial.ext for a partial campaign."""
    stem, ext = os.path.splitext(filename)
    return os.path.join(out_dir, stem + (PARTIAL if partial else "") + ext)


def remove_partial_outputs(out_dir):
    for filename in OUTPUT_FILES:
        path = output_path(out_dir, filename, partial=True)
        if os.path.exists(path):
            os.remove(path)


def write_results(out_dir, campaign_name, spec_path, partial=False):
    """OUT/results.csv and OUT/results.h5 (.partial: see OUTPUT_FILES);
    returns the DataFrame."""
    frame = results_frame(out_dir)
    frame.to_csv(output_path(out_dir, "results.csv", partial), index=False)
    _write_hdf5(output_path(out_dir, "results.h5", partial), frame, campaign_name, spec_path)
    return frame


def _write_hdf5(path, frame, campaign_name, spec_path):
    import h5py
    tmp = path + ".tmp"
    with h5py.File(tmp, "w") as f:
        f.attrs["campaign"] = campaign_name
        f.attrs["spec"] = spec_path
        with open(spec_path, encoding="utf-8") as spec:
            f.attrs["spec_text"] = spec.read()
        group = f.create_group("runs")
        for column in frame.columns:
            values = frame[column]
            if values.dtype.kind in "biuf":
                data = values.to_numpy()
            elif values.dtype.kind == "O" and values.map(lambda v: isinstance(v, bool)).all():
                data = values.to_numpy(dtype=bool)
            else:
                data = np.array(["" if v is None or (isinstance(v, float) and np.isnan(v)) else str(v)
                                 for v in values], dtype=h5py.string_dtype("utf-8"))
            dataset = group.create_dataset(column, data=data)
            dataset.attrs["unit"] = COLUMN_UNITS.get(column, "")
    os.replace(tmp, path)


def read_hdf5(path):
    """results.h5 back into a DataFrame (strings decoded)."""
    import h5py
    import pandas as pd
    columns = {}
    with h5py.File(path, "r") as f:
        for name, dataset in f["runs"].items():
            data = dataset[()]
            if data.dtype.kind in "OS":
                data = [v.decode("utf-8") if isinstance(v, bytes) else v for v in data]
            columns[name] = data
    return pd.DataFrame(columns)
