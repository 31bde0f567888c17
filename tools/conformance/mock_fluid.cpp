#include "tools/conformance/mock_fluid.hpp"

#include <algorithm>
#include <utility>

namespace cosim::conformance {

namespace {

protocol::PeerLink::Settings link_settings(const std::string& token, const std::string& prefix, const std::string& url) {
  protocol::PeerLink::Settings s;
  s.role = "fluid";
  s.token = token;
  s.channel_prefix = prefix;
  s.lcm_url = url;
  return s;
}

}  // namespace

MockFluid::MockFluid(const std::string& token, const std::string& prefix, const std::string& lcm_url, std::ostream& log)
    : token_(token), link_(link_settings(token, prefix, lcm_url), log), outbox_(link_, link_.channels().fluid_state) {}

std::optional<protocol::Ending> MockFluid::open() {
  if (auto e = link_.open()) return e;
  const protocol::Channels& ch = link_.channels();
  const bool ok =
      link_.subscribe<cosimlcm::hello_t>(ch.hello,
                                         [this](cosimlcm::hello_t&& m) {
                                           if (m.role != "solid") return;  // our own, heard back
                                           hellos_.push_back(std::move(m));
                                           if (welcome_) link_.publish(link_.channels().welcome, *welcome_);
                                         }) &&
      link_.subscribe<cosimlcm::solid_state_t>(ch.solid_state,
                                               [this](cosimlcm::solid_state_t&& m) { states_.push_back(std::move(m)); }) &&
      link_.subscribe<cosimlcm::resend_t>(ch.resend,
                                          [this](cosimlcm::resend_t&& m) {
                                            if (m.what != "fluid_state") return;  // our own request
                                            if (answering_) outbox_.answer_resend(m.step);
                                            resends_.push_back(std::move(m));
                                          }) &&
      link_.subscribe<cosimlcm::stop_t>(ch.stop, [this](cosimlcm::stop_t&& m) {
        if (m.sender == "solid") stops_.push_back(std::move(m));
      });
  if (!ok) return protocol::Ending{protocol::exit_code::system, "cannot subscribe to " + ch.prefix + "*", false};
  return std::nullopt;
}

void MockFluid::welcome(const cosimlcm::welcome_t& w) {
  welcome_ = w;
  link_.publish(link_.channels().welcome, w);
}

void MockFluid::send(std::int64_t step, const Eigen::VectorXd& rho, const Eigen::Matrix3Xd& u) {
  cosimlcm::fluid_state_t m = outbox_.next(step);
  const auto n = static_cast<std::size_t>(rho.size());
  m.bulk_velocity_lb = u.cols() > 0 ? u.row(0).mean() : 0.0;
  m.num_cgps = static_cast<std::int32_t>(n);
  m.rho_lb.assign(rho.data(), rho.data() + n);
  m.velocity_lb.assign(n, std::vector<double>(3));
  for (std::size_t l = 0; l < n; ++l)
    for (std::size_t c = 0; c < 3; ++c) m.velocity_lb[l][c] = u(Eigen::Index(c), Eigen::Index(l));
  m.rho_start_lb = m.rho_lb;
  m.velocity_start_lb = m.velocity_lb;
  last_sent_ = m;
  outbox_.publish(std::move(m));
}

void MockFluid::send_again() {
  if (last_sent_) link_.publish(link_.channels().fluid_state, *last_sent_);
}

void MockFluid::ask_resend(std::int64_t step) {
  cosimlcm::resend_t r{};
  r.token = token_;
  r.step = step;
  r.what = "solid_state";
  link_.publish(link_.channels().resend, r);
}

bool MockFluid::pump_until(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const Clock::time_point end = Clock::now() + timeout;
  while (!done()) {
    if (link_.fatal()) return false;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
    if (left.count() <= 0) return false;
    link_.pump(std::min(left, std::chrono::milliseconds(10)));
  }
  return true;
}

const cosimlcm::solid_state_t* MockFluid::first_state(std::int64_t step) const {
  for (const cosimlcm::solid_state_t& m : states_)
    if (m.step == step) return &m;
  return nullptr;
}

int MockFluid::copies_of(std::int64_t step) const {
  return static_cast<int>(std::count_if(states_.begin(), states_.end(),
                                        [step](const cosimlcm::solid_state_t& m) { return m.step == step; }));
}

}  // namespace cosim::conformance
