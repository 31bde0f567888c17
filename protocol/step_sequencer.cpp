#include "protocol/step_sequencer.hpp"

#include <stdexcept>

namespace cosim::protocol {

namespace {
[[noreturn]] void fail_logic(int line, const std::string& what) {
  throw std::logic_error(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}
[[noreturn]] void fail_arg(int line, const std::string& what) {
  throw std::invalid_argument(std::string(__FILE__) + ":" + std::to_string(line) + ": " + what);
}
}  // namespace

// ---- StepSequencer ----

StepSequencer::StepSequencer(std::int64_t first_step)
    : expected_(first_step), highest_step_seen_(first_step - 1) {}

StepSequencer::Verdict StepSequencer::offer(std::int64_t step, std::int64_t seq) {
  if (highest_seq_ && seq < *highest_seq_) ++reordered_;
  if (!highest_seq_ || seq > *highest_seq_) highest_seq_ = seq;
  if (step > highest_step_seen_) highest_step_seen_ = step;

  if (step < expected_) {
    ++stale_;
    return Verdict::Stale;
  }
  if (step > expected_) {
    ++early_;
    return Verdict::Early;
  }
  if (received_) {
    ++duplicates_;
    return Verdict::Duplicate;
  }
  received_ = true;
  ++accepted_;
  return Verdict::Accept;
}

void StepSequencer::advance() {
  if (!received_)
    fail_logic(__LINE__, "advance() past step " + std::to_string(expected_) +
                             " before its message was accepted; wait for it (resend request) "
                             "instead of skipping a step");
  ++expected_;
  received_ = false;
}

// ---- PeerWatch ----

PeerWatch::PeerWatch(std::chrono::milliseconds timeout, std::chrono::milliseconds resend_after)
    : timeout_(timeout), resend_after_(resend_after) {
  if (!(resend_after.count() > 0) || !(resend_after < timeout))
    fail_arg(__LINE__, "peer watch: need 0 < resend_after < timeout; got resend_after = " +
                           std::to_string(resend_after.count()) + " ms, timeout = " +
                           std::to_string(timeout.count()) + " ms");
}

void PeerWatch::heard(time_point now) {
  last_heard_ = now;
  next_resend_ = now + resend_after_;
  resends_ = 0;
}

PeerWatch::Action PeerWatch::poll(time_point now) {
  if (!last_heard_) {
    heard(now);  // the clock starts here
    return Action::Wait;
  }
  if (now - *last_heard_ >= timeout_) return Action::GiveUp;
  if (now >= next_resend_) {
    next_resend_ = now + resend_after_;
    ++resends_;
    return Action::Resend;
  }
  return Action::Wait;
}

// ---- ForeignCounter ----

ForeignCounter::ForeignCounter(std::string run_token, LogHook log)
    : run_token_(std::move(run_token)), log_(std::move(log)) {
  if (run_token_.empty())
    fail_arg(__LINE__, "foreign-token counter: the run token is empty; pass this run's token");
}

bool ForeignCounter::admit(const std::string& channel, const std::string& token) {
  if (token == run_token_) return true;
  const std::int64_t n = ++counts_[channel];
  ++total_;
  if (n == 1 && log_)
    log_("ignoring messages on channel '" + channel + "' with run token '" + token +
         "' (this run's token is '" + run_token_ +
         "'): another run shares the bus; they are counted, never applied");
  return false;
}

void ForeignCounter::unauthenticated(const std::string& channel) {
  ++counts_[channel];
  ++total_;
  ++unauthenticated_;
  if (unauthenticated_by_channel_[channel]++ == 0 && log_)
    log_("ignoring messages on channel '" + channel +
         "' whose MAC does not verify under this run's key (a forger's, or a peer started without the run's "
         "key: $COSIM_RUN_KEY_FILE); they are counted as foreign, never applied");
}

std::int64_t ForeignCounter::count(const std::string& channel) const {
  const auto it = counts_.find(channel);
  return it == counts_.end() ? 0 : it->second;
}

}  // namespace cosim::protocol
