#include "fluid/io/held_body_log.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace cosim::fluid {

HeldBodyLog::HeldBodyLog(const std::string& path, double dt_s, double newtons_per_m, bool sheets)
    : path_(path), dt_s_(dt_s), scale_(newtons_per_m), sheets_(sheets) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  std::fprintf(file_, "step,time_s,drag_N_per_m,lift_N_per_m%s\n",
               sheets ? ",sheet_drag_N_per_m,sheet_lift_N_per_m,total_drag_N_per_m,total_lift_N_per_m" : "");
  std::fflush(file_);
}

HeldBodyLog::~HeldBodyLog() {
  if (file_ != nullptr) std::fclose(file_);
}

void HeldBodyLog::add(const Vec3& force) {
  for (int c = 0; c < 3; ++c) sum_[c] += force[c];
  ++count_;
}

void HeldBodyLog::add(const Vec3& body, const Vec3& sheets) {
  add(body);
  for (int c = 0; c < 3; ++c) sheet_sum_[c] += sheets[c];
}

void HeldBodyLog::record(std::int64_t step) {
  if (count_ == 0) return;
  const double k = scale_ / double(count_);
  const double fx = k * sum_[0], fy = k * sum_[1], sx = k * sheet_sum_[0], sy = k * sheet_sum_[1];
  int ok = std::fprintf(file_, "%lld,%.9g,%.9g,%.9g", static_cast<long long>(step), double(step) * dt_s_, fx, fy);
  if (ok >= 0 && sheets_) ok = std::fprintf(file_, ",%.9g,%.9g,%.9g,%.9g", sx, sy, fx + sx, fy + sy);
  if (ok < 0 || std::fputc('\n', file_) == EOF || std::fflush(file_) != 0)
    throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno));
  sum_ = sheet_sum_ = {0.0, 0.0, 0.0};
  count_ = 0;
}

}  // namespace cosim::fluid
