#include "client/hdf5_export.h"

#include <hdf5.h>

#include <google/protobuf/reflection.h>
#include <google/protobuf/util/json_util.h>

#include "proto/sample_record.h"

namespace tribo::client {

namespace {

// Closes an HDF5 handle at scope exit.
struct Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Handle() {
    if (id >= 0) close(id);
  }
};

std::string json_of(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

hid_t utf8_string_type() {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  return type;
}

bool string_attribute(hid_t object, const std::string& name, const std::string& value) {
  Handle type{utf8_string_type(), H5Tclose};
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  Handle attr{H5Acreate2(object, name.c_str(), type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  const char* data = value.c_str();
  return attr.id >= 0 && H5Awrite(attr.id, type.id, &data) >= 0;
}

bool number_attribute(hid_t object, const std::string& name, double value) {
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  Handle attr{H5Acreate2(object, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
  return attr.id >= 0 && H5Awrite(attr.id, H5T_NATIVE_DOUBLE, &value) >= 0;
}

bool string_dataset(hid_t group, const std::string& name, const std::string& value, const std::string& message_type) {
  Handle type{utf8_string_type(), H5Tclose};
  Handle space{H5Screate(H5S_SCALAR), H5Sclose};
  Handle set{H5Dcreate2(group, name.c_str(), type.id, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose};
  const char* data = value.c_str();
  return set.id >= 0 && H5Dwrite(set.id, type.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, &data) >= 0 &&
         string_attribute(set.id, "message_type", message_type);
}

template <typename T>
bool array_dataset(hid_t group, const std::string& name, const T* data, std::size_t n, hid_t file_type,
                   hid_t memory_type) {
  const hsize_t dims[1] = {n};
  Handle space{H5Screate_simple(1, dims, nullptr), H5Sclose};
  Handle set{H5Dcreate2(group, name.c_str(), file_type, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose};
  if (set.id < 0) return false;
  return n == 0 || H5Dwrite(set.id, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0;
}

struct ChannelInfo {
  std::string name, unit, description, block_field;
};

// The descriptor's channels; a run without one gets the SampleBlock's.
std::vector<ChannelInfo> channels_of(const v1::RunMetadata& metadata) {
  std::vector<ChannelInfo> out;
  for (const auto& c : metadata.run_descriptor().channels()) {
    out.push_back({c.name(), c.unit(), c.description(), c.block_field()});
  }
  if (!out.empty()) return out;
  const auto* d = v1::SampleBlock::descriptor();
  for (int i = 0; i < d->field_count(); ++i) {
    const auto* f = d->field(i);
    if (f->is_repeated()) out.push_back({f->name(), "", "", f->name()});
  }
  return out;
}

bool write_samples(hid_t file, const v1::RunMetadata& metadata, const v1::SampleBlock& samples, std::string& error) {
  Handle group{H5Gcreate2(file, "samples", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
  if (group.id < 0) return error = "cannot create /samples", false;
  const auto* reflection = samples.GetReflection();
  const auto* d = v1::SampleBlock::descriptor();
  for (const ChannelInfo& c : channels_of(metadata)) {
    const auto* field = d->FindFieldByName(c.block_field);
    if (field == nullptr || !field->is_repeated()) continue;
    bool ok = false;
    if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) {
      const auto values = reflection->GetRepeatedFieldRef<double>(samples, field);
      const std::vector<double> data(values.begin(), values.end());
      ok = array_dataset(group.id, c.name, data.data(), data.size(), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE);
    } else if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_UINT32) {
      const auto values = reflection->GetRepeatedFieldRef<std::uint32_t>(samples, field);
      const std::vector<std::uint32_t> data(values.begin(), values.end());
      ok = array_dataset(group.id, c.name, data.data(), data.size(), H5T_STD_U32LE, H5T_NATIVE_UINT32);
    } else {
      continue;
    }
    Handle set{H5Dopen2(group.id, c.name.c_str(), H5P_DEFAULT), H5Dclose};
    ok = ok && set.id >= 0 && string_attribute(set.id, "unit", c.unit) &&
         string_attribute(set.id, "description", c.description) &&
         string_attribute(set.id, "csv_column", c.unit.empty() ? c.name : c.name + "_" + c.unit);
    if (!ok) return error = "cannot write the channel " + c.name, false;
  }
  return true;
}

bool write_documents(hid_t file, const v1::RunMetadata& m, std::string& error) {
  Handle group{H5Gcreate2(file, "run", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
  if (group.id < 0) return error = "cannot create /run", false;
  v1::RunMetadata events, faults;
  *events.mutable_segment_events() = m.segment_events();
  *faults.mutable_faults() = m.faults();
  const bool ok =
      string_dataset(group.id, "start", json_of(m.start()), "tribo.v1.RunStart") &&
      string_dataset(group.id, "stop", json_of(m.stop()), "tribo.v1.RunStop") &&
      string_dataset(group.id, "run_descriptor", json_of(m.run_descriptor()), "tribo.v1.RunDescriptor") &&
      string_dataset(group.id, "segment_events", json_of(events), "tribo.v1.RunMetadata (segment_events only)") &&
      string_dataset(group.id, "faults", json_of(faults), "tribo.v1.RunMetadata (faults only)");
  if (!ok) error = "cannot write the run documents";
  return ok;
}

bool write_root_attributes(hid_t file, const wire::RecordedRun& run) {
  const auto& start = run.metadata.start();
  const auto& stop = run.metadata.stop();
  const auto& notes = start.annotations();
  bool ok = string_attribute(file, "run_id", start.run_id()) &&
            string_attribute(file, "protocol", start.protocol().name()) &&
            string_attribute(file, "exit_status", run.metadata.has_stop() ? v1::ExitStatus_Name(stop.exit_status())
                                                                           : "INCOMPLETE") &&
            string_attribute(file, "reason", stop.reason()) &&
            string_attribute(file, "start_time_utc", start.start_time_utc()) &&
            string_attribute(file, "seed", std::to_string(start.seed())) &&
            string_attribute(file, "software_version", start.software_version()) &&
            number_attribute(file, "loop_rate_hz", start.loop_rate_hz()) &&
            number_attribute(file, "first_sequence", static_cast<double>(run.samples.first_sequence())) &&
            string_attribute(file, "sample", notes.sample()) && string_attribute(file, "tip", notes.tip()) &&
            string_attribute(file, "operator", notes.operator_name()) && string_attribute(file, "note", notes.note());
  for (const auto& [key, value] : notes.extra()) ok = ok && string_attribute(file, "meta." + key, value);
  return ok;
}

}  // namespace

bool write_run_hdf5(const std::string& path, const wire::RecordedRun& run, std::string& error) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors are reported here, not printed by the library
  Handle file{H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose};
  if (file.id < 0) return error = "cannot create " + path, false;
  if (!write_root_attributes(file.id, run)) return error = "cannot write the attributes of " + path, false;
  return write_samples(file.id, run.metadata, run.samples, error) && write_documents(file.id, run.metadata, error);
}

}  // namespace tribo::client
