// `cosim-log export`: one run's state messages as HDF5 time series (HDF5 C API).
#include <hdf5.h>

#include <array>
#include <filesystem>
#include <map>
#include <system_error>

#include "cosimlcm/fluid_state_t.hpp"
#include "cosimlcm/solid_state_t.hpp"
#include "common/hdf5/h5_writer.hpp"
#include "common/hdf5/hdf5_handle.hpp"
#include "common/hdf5/hdf5_quiet.hpp"
#include "tools/log/log_inspector.hpp"

namespace cosim::logtool {

namespace {

namespace fs = std::filesystem;
using protocol::h5_check;
using protocol::H5Id;

// Units as the .lcm comments (protocol/lcm/*.lcm) give them.
constexpr const char* kUnitsStep = "LB steps";
constexpr const char* kUnitsSeq = "1 (the sender's sequence number on the channel)";
constexpr const char* kUnitsUtime = "us since 1970-01-01 UTC (lcm-logger's receive time)";
constexpr const char* kUnitsTime = "s since the log's first event (lcm-logger's receive time)";

void attribute(hid_t obj, const char* name, const std::string& value) {
  protocol::put_attribute(obj, name, value);
}

// Every integer attribute of the export is an int64.
void attribute(hid_t obj, const char* name, std::int64_t value) {
  protocol::put_attribute(obj, name, value);
}

// A dataset with its units, its values written after (write_all, write_row).
H5Id dataset(hid_t group, const char* name, hid_t file_type, const std::vector<hsize_t>& dims,
             const char* units) {
  H5Id d = protocol::create_dataset(group, name, file_type, dims, protocol::DatasetLayout::contiguous(),
                                    std::string("cannot create the dataset ") + name);
  protocol::put_units(d.get(), name, units);
  return d;
}

template <class T>
void write_all(hid_t group, const char* name, const std::vector<T>& v, const char* units) {
  const H5Id d = dataset(group, name, protocol::H5Types<T>::file(), {hsize_t(v.size())}, units);
  protocol::fill_dataset(d.get(), protocol::H5Types<T>::memory(), v.data(), std::string("cannot write the dataset ") + name);
}

// Row `row` of a [rows][n][k] (or [rows][n]) double dataset.
void write_row(hid_t dset, hsize_t row, const std::vector<double>& flat, const char* name) {
  protocol::write_rows(dset, H5T_NATIVE_DOUBLE, row, 1, flat.data(), H5P_DEFAULT,
                       std::string("cannot write a row of ") + name);
}

std::vector<double> flat3(const std::vector<std::vector<double>>& rows) {
  std::vector<double> f;
  f.reserve(rows.size() * 3);
  for (const auto& r : rows) f.insert(f.end(), r.begin(), r.end());
  return f;
}

// The scalars of the first copy of each step, and where that copy is in the log.
struct FirstCopy {
  std::int64_t event_index = 0;
  std::int64_t seq = 0, utime = 0;
  std::int32_t substeps = 0;
  double value = 0;  // solid_time_s or bulk_velocity_lb
};

const RunStats& choose_run(const LogSummary& s, const std::string& want) {
  std::vector<const RunStats*> all, with_state;
  for (const PrefixStats& p : s.prefixes)
    for (const RunStats& r : p.runs) {
      all.push_back(&r);
      if (r.solid.messages + r.fluid.messages > 0) with_state.push_back(&r);
    }
  const auto list = [&] {
    std::string l;
    for (const RunStats* r : with_state)
      l += (l.empty() ? "" : ", ") + r->prefix + " token " + r->token +
           (r->accepted ? " (accepted)" : "");
    return l.empty() ? std::string("none") : l;
  };
  const auto pick = [&](const std::vector<const RunStats*>& c,
                        const std::string& what) -> const RunStats& {
    std::vector<const RunStats*> accepted;
    for (const RunStats* r : c)
      if (r->accepted) accepted.push_back(r);
    if (accepted.size() == 1) return *accepted.front();
    if (c.size() == 1) return *c.front();
    throw LogInputError(s.path + " holds " + std::to_string(c.size()) +
                        " runs with state messages" + what + ": " + list() +
                        "; pick one with --run TOKEN");
  };
  if (with_state.empty())
    throw LogInputError(s.path + ": no decodable solid_state_t or fluid_state_t to export");
  if (want.empty()) return pick(with_state, "");
  std::vector<const RunStats*> match;
  for (const RunStats* r : with_state)
    if (r->token == want) return *r;
  for (const RunStats* r : with_state)
    if (r->prefix == want) match.push_back(r);
  if (match.empty())
    throw LogInputError("--run " + want +
                        ": no run with that token or channel prefix and state messages in " +
                        s.path + "; runs: " + list());
  return pick(match, " on prefix " + want);
}

}  // namespace

ExportResult export_log(const std::string& path, const std::string& out_path,
                        const std::string& want) {
  const LogSummary s = summarize_log(path);
  std::error_code ec;
  if (fs::equivalent(path, out_path, ec))
    throw LogInputError(out_path + ": is the log itself; give another output file");
  const RunStats& run = choose_run(s, want);
  ExportResult res;
  res.prefix = run.prefix;
  res.token = run.token;
  const std::string solid_channel = run.prefix + type_suffix(MsgType::solid_state);
  const std::string fluid_channel = run.prefix + type_suffix(MsgType::fluid_state);

  // Pass 1: the first copy of each step.
  std::map<std::int64_t, FirstCopy> solid, fluid;
  {
    LogReader reader(path);
    LogEvent e;
    for (std::int64_t index = 0; reader.next(e); ++index) {
      if (e.channel == solid_channel) {
        cosimlcm::solid_state_t m{};
        if (!decode_as(e.data, m).empty() || m.token != run.token) continue;
        const bool fresh =
            solid.try_emplace(m.step, FirstCopy{index, m.seq, e.utime, m.substeps, m.solid_time_s})
                .second;
        if (!fresh) ++res.solid_skipped;
      } else if (e.channel == fluid_channel) {
        cosimlcm::fluid_state_t m{};
        if (!decode_as(e.data, m).empty() || m.token != run.token) continue;
        const bool fresh =
            fluid.try_emplace(m.step, FirstCopy{index, m.seq, e.utime, 0, m.bulk_velocity_lb})
                .second;
        if (!fresh) ++res.fluid_skipped;
      }
    }
  }
  if (run.solid.num_cgps_changes > 0 || run.fluid.num_cgps_changes > 0)
    throw LogInputError(path + ": cannot export token " + run.token + ": num_cgps changes within " +
                        (run.solid.num_cgps_changes > 0 ? solid_channel : fluid_channel));
  const auto solid_cgps = hsize_t(std::max<std::int64_t>(run.solid.num_cgps, 0));
  const auto fluid_cgps = hsize_t(std::max<std::int64_t>(run.fluid.num_cgps, 0));

  // Rows in step order; event index -> row.
  std::map<std::int64_t, hsize_t> solid_row, fluid_row;
  std::vector<std::int64_t> s_step, s_seq, s_utime, f_step, f_seq, f_utime;
  std::vector<double> s_time_rel, s_time, f_time_rel, f_bulk;
  std::vector<std::int32_t> s_sub;
  for (const auto& [step, c] : solid) {
    solid_row[c.event_index] = s_step.size();
    s_step.push_back(step);
    s_seq.push_back(c.seq);
    s_utime.push_back(c.utime);
    s_time_rel.push_back(double(c.utime - s.first_utime) * 1e-6);
    s_sub.push_back(c.substeps);
    s_time.push_back(c.value);
  }
  for (const auto& [step, c] : fluid) {
    fluid_row[c.event_index] = f_step.size();
    f_step.push_back(step);
    f_seq.push_back(c.seq);
    f_utime.push_back(c.utime);
    f_time_rel.push_back(double(c.utime - s.first_utime) * 1e-6);
    f_bulk.push_back(c.value);
  }

  const protocol::H5Quiet quiet;
  try {
    H5Id file(H5Fcreate(out_path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
              "cannot create " + out_path);
    attribute(file.get(), "source_log", path);
    attribute(file.get(), "channel_prefix", run.prefix);
    attribute(file.get(), "token", run.token);
    attribute(file.get(), "welcome_accepted", std::int64_t(run.accepted ? 1 : 0));
    attribute(file.get(), "total_steps", run.total_steps);
    attribute(file.get(), "rigid_steps", run.rigid_steps);
    attribute(file.get(), "time_ratio", run.time_ratio);
    attribute(
        file.get(), "description",
        "cosim-log export: the run's state messages, one row per step in step order (the first "
        "copy of each step as logged); protocol/README.md gives the fields");
    {  // every group and dataset is closed before the file
      const H5Id gs(H5Gcreate2(file.get(), "solid_state", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                    H5Gclose, "cannot create the group solid_state");
      attribute(gs.get(), "channel", solid_channel);
      attribute(gs.get(), "num_cgps", std::int64_t(solid_cgps));
      attribute(gs.get(), "steps_missing", run.solid.steps_missing);
      attribute(gs.get(), "copies_left_out", res.solid_skipped);
      write_all(gs.get(), "step", s_step, kUnitsStep);
      write_all(gs.get(), "seq", s_seq, kUnitsSeq);
      write_all(gs.get(), "log_utime", s_utime, kUnitsUtime);
      write_all(gs.get(), "log_time_s", s_time_rel, kUnitsTime);
      write_all(gs.get(), "substeps", s_sub,
                "CGP substeps (A_T, or 0 while rigid)");
      write_all(gs.get(), "solid_time_s", s_time, "s");
      const hsize_t sn = s_step.size();
      const H5Id pos =
          dataset(gs.get(), "position_lb", H5T_IEEE_F64LE, {sn, solid_cgps, 3},
                  "dx_LB (lattice coordinates: node (0,0,0) is the first fluid cell centre, "
                  "the plate surface is y = -1/2)");
      const H5Id imp = dataset(
          gs.get(), "impulse_lb", H5T_IEEE_F64LE, {sn, solid_cgps, 3},
          "rho_0 dx^3 c (lattice momentum), impulse given to the fluid over the LB interval");

      const H5Id gf(H5Gcreate2(file.get(), "fluid_state", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                    H5Gclose, "cannot create the group fluid_state");
      attribute(gf.get(), "channel", fluid_channel);
      attribute(gf.get(), "num_cgps", std::int64_t(fluid_cgps));
      attribute(gf.get(), "steps_missing", run.fluid.steps_missing);
      attribute(gf.get(), "copies_left_out", res.fluid_skipped);
      write_all(gf.get(), "step", f_step, kUnitsStep);
      write_all(gf.get(), "seq", f_seq, kUnitsSeq);
      write_all(gf.get(), "log_utime", f_utime, kUnitsUtime);
      write_all(gf.get(), "log_time_s", f_time_rel, kUnitsTime);
      write_all(gf.get(), "bulk_velocity_lb", f_bulk,
                "c = dx/dt_LB (U_b, Eq. 34, as of the fluid's latest health check)");
      const hsize_t fn = f_step.size();
      const H5Id rho = dataset(gf.get(), "rho_lb", H5T_IEEE_F64LE, {fn, fluid_cgps}, "rho_0");
      const H5Id vel =
          dataset(gf.get(), "velocity_lb", H5T_IEEE_F64LE, {fn, fluid_cgps, 3}, "c = dx/dt_LB");

      // Pass 2: the arrays, row by row.
      LogReader reader(path);
      LogEvent e;
      for (std::int64_t index = 0; reader.next(e); ++index) {
        if (const auto it = solid_row.find(index); it != solid_row.end()) {
          cosimlcm::solid_state_t m{};
          decode_as(e.data, m);
          write_row(pos.get(), it->second, flat3(m.position_lb), "position_lb");
          write_row(imp.get(), it->second, flat3(m.impulse_lb), "impulse_lb");
        } else if (const auto jt = fluid_row.find(index); jt != fluid_row.end()) {
          cosimlcm::fluid_state_t m{};
          decode_as(e.data, m);
          write_row(rho.get(), jt->second, m.rho_lb, "rho_lb");
          write_row(vel.get(), jt->second, flat3(m.velocity_lb), "velocity_lb");
        }
      }
    }
    file.close("cannot close " + out_path);
  } catch (...) {
    fs::remove(out_path, ec);
    throw;
  }
  res.solid_rows = std::int64_t(solid.size());
  res.fluid_rows = std::int64_t(fluid.size());
  return res;
}

}  // namespace cosim::logtool
