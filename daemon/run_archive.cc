#include "daemon/run_archive.h"

#include <algorithm>

#include "proto/run_files.h"

namespace tribo::daemon {

namespace fs = std::filesystem;

namespace {

v1::Error make_error(v1::ErrorCode code, std::string field, std::string message) {
  v1::Error e;
  e.set_code(code);
  e.set_field(std::move(field));
  e.set_message(std::move(message));
  return e;
}

// The run's directory, or the error naming `field`.
std::optional<v1::Error> run_directory(const fs::path& data_dir, const std::string& run_id,
                                       const std::string& field, fs::path& dir) {
  if (!wire::is_valid_run_id(run_id)) {
    return make_error(v1::INVALID_ARGUMENT, field,
                      "run id \"" + run_id.substr(0, 64) + "\" is not a run directory name");
  }
  dir = data_dir / run_id;
  if (!fs::exists(dir / wire::kMetadataFile)) {
    return make_error(v1::NOT_FOUND, field, "no recorded run \"" + run_id + "\"");
  }
  return std::nullopt;
}

wire::SampleRange page(std::uint64_t from, std::uint64_t asked, std::uint64_t limit) {
  return wire::SampleRange{from, asked == 0 ? limit : std::min(asked, limit)};
}

constexpr std::size_t kIndexedRuns = 16;

// A listing fits one reply whatever the data directory holds: strings are cut
// (runs recorded before they were bounded may carry megabytes).
void cut_strings(v1::RunListing& run) {
  constexpr std::size_t kMaxListedString = 256;
  const auto cut = [](std::string* s) {
    if (s->size() > kMaxListedString) s->resize(kMaxListedString);
  };
  cut(run.mutable_protocol_name());
  cut(run.mutable_reason());
  auto* a = run.mutable_annotations();
  for (std::string* s : {a->mutable_sample(), a->mutable_tip(), a->mutable_operator_name(), a->mutable_note()}) cut(s);
}

}  // namespace

wire::RowIndex& RunArchive::index_of(const std::string& run_id) {
  if (indexes_.size() >= kIndexedRuns && indexes_.count(run_id) == 0) indexes_.clear();
  return indexes_[run_id];
}

const v1::RunListing* RunArchive::kept_listing(const fs::path& dir, MetadataStamp& stamp) const {
  std::error_code size_error, time_error;
  stamp.bytes = fs::file_size(dir / wire::kMetadataFile, size_error);
  stamp.modified = fs::last_write_time(dir / wire::kMetadataFile, time_error);
  stamp.readable = !size_error && !time_error;
  const auto kept = listings_.find(dir.filename().string());
  if (!stamp.readable || kept == listings_.end() || kept->second.stamp.bytes != stamp.bytes ||
      kept->second.stamp.modified != stamp.modified) {
    return nullptr;
  }
  return &kept->second.listing;
}

std::optional<v1::RunListing> RunArchive::listing_of(const fs::path& dir) {
  MetadataStamp stamp;
  if (const v1::RunListing* kept = kept_listing(dir, stamp)) {
    v1::RunListing listing = *kept;
    // A run being recorded: its samples file grows under an unchanged metadata.json.
    if (!listing.finalized()) listing.set_sample_count(wire::count_recorded_samples(dir));
    return listing;
  }
  const std::string run_id = dir.filename().string();
  listings_.erase(run_id);
  auto listing = stamp.readable ? wire::read_run_listing(dir) : std::nullopt;
  if (!listing) return std::nullopt;
  cut_strings(*listing);
  listings_[run_id] = CachedListing{stamp, *listing};
  return listing;
}

// Only the stop document is asked for: a run being recorded is not counted
// (its listing would scan the whole samples file on every page fetched).
bool RunArchive::finalized(const fs::path& dir) {
  MetadataStamp stamp;
  if (const v1::RunListing* kept = kept_listing(dir, stamp)) return kept->finalized();
  std::string error;
  const auto metadata = wire::read_run_metadata(dir, error);
  return metadata && metadata->has_stop();
}

// The listing stops, marked truncated, before the reply outgrows kMaxListingBytes.
v1::ListRunsReply RunArchive::list_runs(const v1::ListRuns& request) {
  constexpr std::size_t kMaxListingBytes = 2u << 20;
  std::vector<v1::RunListing> runs;
  std::map<std::string, CachedListing> seen;  // runs no longer on disk leave the cache
  for (const auto& dir : wire::recorded_run_directories(data_dir_)) {
    auto listing = listing_of(dir);
    if (!listing) continue;
    if (auto c = listings_.find(listing->run_id()); c != listings_.end()) seen.insert(listings_.extract(c));
    runs.push_back(std::move(*listing));
  }
  listings_ = std::move(seen);
  wire::sort_newest_first(runs);
  v1::ListRunsReply reply;
  std::size_t bytes = 0;
  for (auto& run : runs) {
    if (request.max_runs() > 0 && reply.runs_size() >= static_cast<int>(request.max_runs())) break;
    const std::size_t size = run.ByteSizeLong() + 8;
    if (bytes + size > kMaxListingBytes) {
      reply.set_truncated(true);
      break;
    }
    bytes += size;
    *reply.add_runs() = std::move(run);
  }
  return reply;
}

std::optional<v1::Error> RunArchive::get_run(const v1::GetRun& request, v1::GetRunReply& reply) const {
  fs::path dir;
  if (auto e = run_directory(data_dir_, request.run_id(), "get_run.run_id", dir)) return e;
  std::string error;
  auto metadata = wire::read_run_metadata(dir, error);
  if (!metadata) return make_error(v1::INTERNAL, "get_run.run_id", error);
  *reply.mutable_metadata() = std::move(*metadata);
  reply.set_recorded_samples(wire::count_recorded_samples(dir));
  return std::nullopt;
}

std::optional<v1::Error> RunArchive::fetch_samples(const v1::FetchSamples& request,
                                                   v1::FetchSamplesReply& reply) {
  fs::path dir;
  if (auto e = run_directory(data_dir_, request.run_id(), "fetch_samples.run_id", dir)) return e;
  // Read "finished" first: a run finalized after this still has every row read below.
  reply.set_run_finished(finalized(dir));
  std::string error;
  wire::RowsRead read;
  v1::SampleBlock* block = reply.mutable_samples();
  if (!wire::read_sample_rows(dir, page(request.from_sequence(), request.max_samples(), kMaxFetchSamples),
                              *block, read, error, &index_of(request.run_id()))) {
    return make_error(v1::INTERNAL, "fetch_samples.run_id", error);
  }
  block->set_run_id(request.run_id());
  reply.set_next_sequence(request.from_sequence() + read.rows);
  reply.set_end_of_recording(read.end_of_file);
  return std::nullopt;
}

std::optional<v1::Error> RunArchive::export_csv(const v1::ExportCsv& request, v1::ExportCsvReply& reply) {
  fs::path dir;
  if (auto e = run_directory(data_dir_, request.run_id(), "export_csv.run_id", dir)) return e;
  reply.set_run_finished(finalized(dir));
  std::string error;
  wire::RowsRead read;
  if (!wire::read_csv_rows(dir, page(request.from_sequence(), request.max_samples(), kMaxExportRows),
                           *reply.mutable_csv(), read, error, &index_of(request.run_id()))) {
    return make_error(v1::INTERNAL, "export_csv.run_id", error);
  }
  reply.set_next_sequence(request.from_sequence() + read.rows);
  reply.set_end_of_recording(read.end_of_file);
  return std::nullopt;
}

}  // namespace tribo::daemon
