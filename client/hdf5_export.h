// `tribo export --format hdf5`: a recorded run in one HDF5 file, readable
// with h5py:
//   /                  attributes: run_id, protocol, exit_status, reason,
//                      start_time_utc, seed, software_version, loop_rate_hz,
//                      first_sequence and the user's annotations (sample, tip,
//                      operator, note, meta.KEY)
//   /samples/NAME      one 1-D dataset per channel (float64; segment_index
//                      and status_flags uint32), attributes unit,
//                      description, csv_column
//   /run/start, /run/stop, /run/run_descriptor, /run/segment_events,
//   /run/faults        the run documents, each a scalar UTF-8 string dataset
//                      holding the protobuf message as JSON (proto field
//                      names), attribute message_type
#pragma once

#include <string>

#include "proto/run_files.h"

namespace tribo::client {

// Writes (replacing) path; false and error set on failure.
bool write_run_hdf5(const std::string& path, const wire::RecordedRun& run, std::string& error);

}  // namespace tribo::client
