#include "fluid/io/held_body_log.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace cosim::fluid {

HeldBodyLog::HeldBodyLog(const std::string& path, double dt_s, double newtons_per_m)
    : path_(path), dt_s_(dt_s), scale_(newtons_per_m) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  std::fprintf(file_, "step,time_s,drag_N_per_m,lift_N_per_m\n");
  std::fflush(file_);
}

HeldBodyLog::~HeldBodyLog() {
  if (file_ != nullptr) std::fclose(file_);
}

void HeldBodyLog::add(const Vec3& force) {
  for (int c = 0; c < 3; ++c) sum_[c] += force[c];
  ++count_;
}

void HeldBodyLog::record(std::int64_t step) {
  if (count_ == 0) return;
  const double fx = scale_ * sum_[0] / double(count_), fy = scale_ * sum_[1] / double(count_);
  if (std::fprintf(file_, "%lld,%.9g,%.9g,%.9g\n", static_cast<long long>(step), double(step) * dt_s_, fx, fy) < 0 ||
      std::fflush(file_) != 0)
    throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno));
  sum_ = {0.0, 0.0, 0.0};
  count_ = 0;
}

}  // namespace cosim::fluid
