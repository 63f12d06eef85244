// Answers the API's questions about recorded runs (list, metadata, fetch,
// CSV export) from the data directory, the running run included: whatever
// has been streamed is on disk already. Run ids are checked to name a
// directory right under the data directory before any path is built.
#pragma once

#include <filesystem>
#include <optional>

#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

// The most samples one reply carries (a page stays well below 4 MiB).
inline constexpr std::uint64_t kMaxFetchSamples = 32768;
inline constexpr std::uint64_t kMaxExportRows = 16384;

v1::ListRunsReply list_runs(const std::filesystem::path& data_dir, const v1::ListRuns& request);
std::optional<v1::Error> get_run(const std::filesystem::path& data_dir, const v1::GetRun& request,
                                 v1::GetRunReply& reply);
std::optional<v1::Error> fetch_samples(const std::filesystem::path& data_dir,
                                       const v1::FetchSamples& request, v1::FetchSamplesReply& reply);
std::optional<v1::Error> export_csv(const std::filesystem::path& data_dir, const v1::ExportCsv& request,
                                    v1::ExportCsvReply& reply);

}  // namespace tribo::daemon
