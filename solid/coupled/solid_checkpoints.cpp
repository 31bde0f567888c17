#include "solid/coupled/solid_checkpoints.hpp"

#include <filesystem>
#include <stdexcept>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "cosimlcm/solid_state_t.hpp"
#include "solid/io/solid_log.hpp"
#include "common/run/checkpoint_file.hpp"
#include "protocol/checkpoint_identity.hpp"
#include "solid/watchdog/energy_watch_checkpoint.hpp"
#include "protocol/handshake.hpp"
#include "common/text/text.hpp"
#include "solid/schemes/solid_scheme.hpp"
#include "solid/io/sheet_snapshots.hpp"
#include "solid/coupled/server_solid.hpp"
#include "solid/coupled/solid_peer.hpp"
#include "solid/coupled/solid_run.hpp"

namespace cosim::solid {

std::string SolidCheckpoints::write(const std::string& reason) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(s_.output_dir) / "checkpoints";
  fs::create_directories(dir);
  const fs::path file = dir / protocol::checkpoint_name("solid", peer_.last_step());
  protocol::CheckpointWriter w(file);
  const std::optional<SolidScheme::RestartPoint> point = scheme_.restart_point();
  w.attr("step", peer_.last_step());
  w.attr("solid_seq", point ? point->in_flight->seq + 1 : peer_.next_seq());
  const SchemeContext ctx{solid_, peer_, out_};
  scheme_.save(w, ctx);
  w.attr("total_substeps", run_.total_substeps());
  w.attr("num_cgps", static_cast<std::int64_t>(run_.num_cgps()));
  protocol::save_energy_watch(w, run_.energy_watch().state(), "watchdog_", "_J");
  protocol::write_identity(w, {s_.path, o_.run_id, run_.coupling().time_ratio, o_.new_time_ratio});
  w.text("reason", reason.empty() ? "every coupling.checkpoint_every steps" : reason);
  const SolidState st = point ? solid_.kept_start() : run_.model().state();
  w.text("model", st.model);
  w.put("positions_bohr", st.positions_bohr.data(), std::size_t(st.positions_bohr.size()));
  w.put("velocities_au", st.velocities_au.data(), std::size_t(st.velocities_au.size()));
  w.put("external_forces_au", st.external_forces_au.data(), std::size_t(st.external_forces_au.size()));
  // The solid_state_t of the step in flight: the fluid has not applied it yet.
  const cosimlcm::solid_state_t& sent = point ? *point->in_flight : peer_.last_sent();
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(sent.getEncodedSize()));
  sent.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  w.put("in_flight_solid_state", bytes);
  CoupledSeries& series = run_.series();
  w.put("series_step", series.step);
  for (const auto& [name, column] : series.columns()) w.put(std::string("series_") + name, *column);
  w.commit();
  protocol::prune_checkpoints(dir, "solid_", 3, o_.run_id);
  return file.string();
}

std::optional<protocol::Ending> SolidCheckpoints::write_if_due(std::int64_t step) {
  const std::int64_t every = run_.coupling().checkpoint_every;
  if (every <= 0 || step % every != 0) return std::nullopt;
  try {
    write("");
  } catch (const std::exception& e) {
    return protocol::Ending{exit_code::system,
                            "checkpoint of step " + std::to_string(step) + ": " + protocol::one_line(e.what()), true};
  }
  return std::nullopt;
}

void SolidCheckpoints::restore(const std::string& path) {
  const protocol::CheckpointReader r(path);
  protocol::check_identity(r, {s_.path, o_.run_id, run_.coupling().time_ratio, o_.new_time_ratio});
  const std::int64_t total_steps = peer_.total_steps();
  const std::int64_t step = r.int64_attr("step");
  if (step >= total_steps && step >= 1)
    throw std::runtime_error("step = " + std::to_string(step) + ": the run already ends there (" +
                             std::to_string(total_steps) + " steps); to continue it, raise [run] steps above " +
                             std::to_string(step));
  if (step < 1 || step >= total_steps)
    throw std::runtime_error("step = " + std::to_string(step) + ", allowed: 1 to " + std::to_string(total_steps - 1));
  const Eigen::Index n = run_.num_cgps();
  const auto size = static_cast<std::size_t>(3 * n);
  SolidState st;
  st.model = r.text("model");
  st.positions_bohr = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("positions_bohr", size).data(), 3, n);
  st.velocities_au = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("velocities_au", size).data(), 3, n);
  st.external_forces_au = Eigen::Map<const Eigen::Matrix3Xd>(r.doubles("external_forces_au", size).data(), 3, n);
  run_.model().restore(st);  // std::invalid_argument: another model or CGP count
  cosimlcm::solid_state_t sent{};
  const std::vector<std::uint8_t> bytes = r.bytes("in_flight_solid_state");
  if (sent.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0 || sent.step != step || sent.num_cgps != n)
    throw std::runtime_error("in_flight_solid_state is not the solid_state_t of step " + std::to_string(step));
  sent.token = peer_.token();  // this run's; the rest of the message is the one sent before
  CoupledSeries& series = run_.series();
  series.sheets = static_cast<int>(s_.config.sheets.size());
  series.step = r.int64s("series_step");
  for (const auto& [name, column] : series.columns()) *column = r.doubles(std::string("series_") + name);
  const std::int64_t next_seq = r.int64_attr("solid_seq");
  std::int64_t total_substeps = r.int64_attr("total_substeps");
  // A restart with another A_T (the launcher's watchdog retry): the state does not depend on
  // it, the substep count does (solid_time_s = substeps x dt_CG is physical time); the
  // in-flight solid_state_t keeps the substeps it was computed with, and the coordinator
  // accepts them for its step (its checkpoint holds the old A_T too). The implicit scheme
  // replaces it instead (its restore()).
  const int time_ratio = run_.coupling().time_ratio;
  bool ratio_changed = false;
  if (r.has("time_ratio")) {
    const std::int64_t old_ratio = r.int64_attr("time_ratio");
    if (old_ratio < 1 || total_substeps % old_ratio != 0)
      throw std::runtime_error("time_ratio = " + std::to_string(old_ratio) +
                               " does not divide total_substeps = " + std::to_string(total_substeps));
    if (old_ratio != time_ratio) {
      solid_log().info(out_) << "the checkpoint ran A_T = " << old_ratio << ", this run A_T = " << time_ratio << ": "
                             << total_substeps / old_ratio << " dynamic LB steps so far";
      total_substeps = total_substeps / old_ratio * time_ratio;
      ratio_changed = true;
    }
  }
  run_.set_total_substeps(total_substeps);
  if (const auto ew = protocol::read_energy_watch(r, "watchdog_", "_J")) {
    run_.energy_watch().restore(*ew);
  } else {
    run_.reference_energy(step);  // an older checkpoint: E here is E(0)
  }
  SchemeContext ctx{solid_, peer_, out_};
  peer_.await_from(scheme_.restore(r, step, ratio_changed, sent, ctx));
  if (SheetSnapshotWriter* snapshots = run_.snapshots())
    for (std::int64_t k = 0; k <= step; ++k)
      if (sheet_snapshot_due(k, total_steps - 1, s_.sheets_every))
        snapshots->adopt(k, static_cast<double>(k) * run_.units().dt_lb_s());
  // Bit for bit but for the token (and the implicit scheme's first iterate at another A_T).
  peer_.resume(std::move(sent), next_seq);
}

}  // namespace cosim::solid
