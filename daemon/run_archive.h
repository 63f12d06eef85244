// Answers the API's questions about recorded runs (list, metadata, fetch,
// CSV export) from the data directory, the running run included: whatever
// has been streamed is on disk already. Run ids are checked to name a
// directory right under the data directory before any path is built.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "proto/run_files.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

// The most samples one reply carries (a page stays well below 4 MiB).
inline constexpr std::uint64_t kMaxFetchSamples = 32768;
inline constexpr std::uint64_t kMaxExportRows = 16384;

// Keeps a row index per recently read run, so that paging costs a seek, and
// the listing of every run, so that listing a data directory of many
// runs reads one small file per run only when that file changed (each listing
// otherwise parses every run's metadata.json).
// Not thread-safe: the API server uses it from its io thread.
class RunArchive {
 public:
  explicit RunArchive(std::filesystem::path data_dir) : data_dir_(std::move(data_dir)) {}

  v1::ListRunsReply list_runs(const v1::ListRuns& request);
  std::optional<v1::Error> get_run(const v1::GetRun& request, v1::GetRunReply& reply) const;
  std::optional<v1::Error> fetch_samples(const v1::FetchSamples& request, v1::FetchSamplesReply& reply);
  std::optional<v1::Error> export_csv(const v1::ExportCsv& request, v1::ExportCsvReply& reply);

 private:
  wire::RowIndex& index_of(const std::string& run_id);
  // dir's listing, its strings cut to the listing's bounds; nullopt if dir
  // holds no readable metadata.json.
  std::optional<v1::RunListing> listing_of(const std::filesystem::path& dir);
  bool finalized(const std::filesystem::path& dir);

  // A run's listing, valid while its metadata.json keeps this size and
  // modification time (the stop document rewrites it). A run being recorded
  // has its sample count taken afresh from the samples file, which grows under
  // an unchanged metadata.json.
  struct MetadataStamp {
    bool readable = false;
    std::uintmax_t bytes = 0;
    std::filesystem::file_time_type modified;
  };
  struct CachedListing {
    MetadataStamp stamp;
    v1::RunListing listing;
  };
  // dir's kept listing if its metadata.json is unchanged, else null; stamp
  // receives the file's present size and time.
  const v1::RunListing* kept_listing(const std::filesystem::path& dir, MetadataStamp& stamp) const;

  std::filesystem::path data_dir_;
  std::map<std::string, wire::RowIndex> indexes_;
  std::map<std::string, CachedListing> listings_;
};

}  // namespace tribo::daemon
