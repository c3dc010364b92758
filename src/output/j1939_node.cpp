#include "sitepose/output/j1939_node.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "sitepose/core/enum_names.hpp"

namespace sitepose::output {

namespace {

constexpr std::uint8_t kPriorityHeartbeat = 7;
constexpr std::uint8_t kPriorityProductInformation = 6;
constexpr std::int64_t kNsPerMs = 1'000'000;
constexpr std::int64_t kMaxSettleNs = 10'000'000'000;
constexpr std::int64_t kMinHeartbeatNs = 10'000'000;       // 0.01 s: the field's resolution
constexpr std::int64_t kMaxHeartbeatNs = 655'320'000'000;  // largest valid u16 0.01 s value

CanFrame with_source_address(CanFrame f, std::uint8_t source_address) {
  f.id = (f.id & ~std::uint32_t{0xFF}) | source_address;
  return f;
}

Status invalid(const std::string& message) { return make_error(ErrorCode::kInvalidArgument, message); }

}  // namespace

Status check_j1939_node_options(const J1939NodeOptions& o) {
  SITEPOSE_TRY_STATUS(check_j1939_name(o.name));
  if (o.preferred_address > kJ1939MaxUnicastAddress) {
    return invalid("J1939 preferred address = " + std::to_string(o.preferred_address) + ": must be 0..253");
  }
  if (o.first_dynamic_address > o.last_dynamic_address || o.last_dynamic_address > kJ1939MaxUnicastAddress) {
    return invalid("J1939 dynamic address range " + std::to_string(o.first_dynamic_address) + ".." +
                   std::to_string(o.last_dynamic_address) + ": must be ordered and within 0..253");
  }
  if (o.claim_settle_ns < 0 || o.claim_settle_ns > kMaxSettleNs) {
    return invalid("J1939 claim settle time = " + std::to_string(o.claim_settle_ns) + " ns: must be 0..10 s");
  }
  if (o.heartbeat_interval_ns != 0 &&
      (o.heartbeat_interval_ns < kMinHeartbeatNs || o.heartbeat_interval_ns > kMaxHeartbeatNs)) {
    return invalid("NMEA 2000 heartbeat interval = " + std::to_string(o.heartbeat_interval_ns) +
                   " ns: must be 0 (off) or 0.01..655.32 s");
  }
  return check_n2k_product_information(o.product);
}

constexpr auto kJ1939AddressStateNames =
    enum_names<J1939AddressState>({{J1939AddressState::kStopped, "stopped"},
                                   {J1939AddressState::kClaiming, "claiming"},
                                   {J1939AddressState::kClaimed, "claimed"},
                                   {J1939AddressState::kCannotClaim, "cannot-claim"}});

const char* to_string(J1939AddressState state) { return kJ1939AddressStateNames.name(state); }

J1939Node::J1939Node(J1939NodeOptions options)
    : options_(std::move(options)), name_(0), address_(options_.preferred_address) {
  SITEPOSE_CHECK(check_j1939_node_options(options_).has_value());
  name_ = pack_j1939_name(options_.name);
}

std::uint8_t J1939Node::address() const {
  return state_ == J1939AddressState::kClaiming || state_ == J1939AddressState::kClaimed ? address_
                                                                                         : kJ1939NullAddress;
}

void J1939Node::start(std::int64_t now_ns) {
  if (state_ == J1939AddressState::kCannotClaim) return;  // stays silent (J1939-81)
  claimed_by_others_.clear();                             // the bus may have changed while we were away
  claim(address_, now_ns);
}

void J1939Node::stop() {
  if (state_ != J1939AddressState::kCannotClaim) state_ = J1939AddressState::kStopped;
  outgoing_.clear();
  settle_deadline_ns_ = heartbeat_due_ns_ = cannot_claim_due_ns_ = kNever;
}

void J1939Node::claim(std::uint8_t address, std::int64_t now_ns) {
  address_ = address;
  state_ = J1939AddressState::kClaiming;
  settle_deadline_ns_ = now_ns + options_.claim_settle_ns;
  heartbeat_due_ns_ = kNever;
  outgoing_.push_back(encode_address_claimed(name_, address_));
  ++counters_.claims_sent;
}

void J1939Node::on_frame(const CanFrame& frame, std::int64_t now_ns) {
  if (state_ == J1939AddressState::kStopped) return;
  if (auto claim = parse_address_claimed(frame)) {
    on_address_claimed(*claim, now_ns);
  } else if (auto request = parse_request(frame)) {
    on_request(*request, now_ns);
  }
}

void J1939Node::on_address_claimed(const AddressClaim& claim, std::int64_t now_ns) {
  // Whoever held this NAME elsewhere has moved (or given up, address 254).
  std::erase_if(claimed_by_others_, [&](const auto& kv) { return kv.second == claim.name; });
  if (claim.source_address == kJ1939NullAddress) return;
  if (claim.name == name_) {
    ++counters_.name_conflicts;  // NAMEs must be unique on a bus: an installation error
    return;
  }
  claimed_by_others_[claim.source_address] = claim.name;
  const bool contest = claim.source_address == address_ &&
                       (state_ == J1939AddressState::kClaiming || state_ == J1939AddressState::kClaimed);
  if (!contest) return;
  if (name_ < claim.name) {
    ++counters_.contests_won;
    outgoing_.push_back(encode_address_claimed(name_, address_));
    ++counters_.claims_sent;
  } else {
    ++counters_.contests_lost;
    lose_contest(now_ns);
  }
}

void J1939Node::lose_contest(std::int64_t now_ns) {
  if (options_.name.arbitrary_address_capable) {
    if (auto next = free_dynamic_address()) {
      ++counters_.address_changes;
      claim(*next, now_ns);
      return;
    }
  }
  state_ = J1939AddressState::kCannotClaim;
  settle_deadline_ns_ = heartbeat_due_ns_ = kNever;
  outgoing_.push_back(encode_address_claimed(name_, kJ1939NullAddress));
  ++counters_.claims_sent;
}

std::optional<std::uint8_t> J1939Node::free_dynamic_address() const {
  const int first = options_.first_dynamic_address;
  const int count = options_.last_dynamic_address - first + 1;
  // Start after the current address when it is in the range, so a node that
  // loses twice does not retry the address it just lost.
  const int start = (address_ >= first && address_ - first < count) ? address_ - first + 1 : 0;
  for (int i = 0; i < count; ++i) {
    const auto candidate = static_cast<std::uint8_t>(first + (start + i) % count);
    if (candidate != address_ && !claimed_by_others_.contains(candidate)) return candidate;
  }
  return std::nullopt;
}

bool J1939Node::is_for_me(std::uint8_t destination) const {
  return destination == kJ1939GlobalAddress ||
         (destination == address_ && state_ != J1939AddressState::kCannotClaim);
}

void J1939Node::refuse(const Request& request, AckControl control) {
  if (request.destination == kJ1939GlobalAddress) return;  // no answers to a global request
  outgoing_.push_back(encode_acknowledgement(control, request.pgn, request.requester, address_));
  ++counters_.requests_refused;
}

void J1939Node::on_request(const Request& request, std::int64_t now_ns) {
  if (!is_for_me(request.destination)) return;
  if (request.pgn == kPgnAddressClaimed) {
    if (state_ == J1939AddressState::kCannotClaim) {
      // Pseudo-random 0..153 ms from the NAME, so nodes that all failed do
      // not answer at once.
      const auto delay_ms = static_cast<std::int64_t>((name_ ^ (name_ >> 29)) % 154);
      cannot_claim_due_ns_ = std::min(cannot_claim_due_ns_, now_ns + delay_ms * kNsPerMs);
    } else {
      outgoing_.push_back(encode_address_claimed(name_, address_));
      ++counters_.claims_sent;
    }
    ++counters_.requests_answered;
    return;
  }
  if (!may_transmit()) return;
  if (request.pgn == kPgnHeartbeat) {
    send_heartbeat(now_ns);
  } else if (request.pgn == kPgnProductInformation) {
    const auto id = make_j1939_id(
        J1939Id{kPriorityProductInformation, kPgnProductInformation, address_, kJ1939GlobalAddress});
    auto frames =
        fast_packet_frames(*id, encode_n2k_product_information_payload(options_.product), product_sequence_);
    SITEPOSE_CHECK(frames.has_value());  // 134 bytes fit a fast packet
    product_sequence_ = static_cast<std::uint8_t>((product_sequence_ + 1) & 0x7);
    outgoing_.insert(outgoing_.end(), frames->begin(), frames->end());
  } else if (auto it = last_messages_.find(request.pgn); it != last_messages_.end()) {
    for (const CanFrame& f : it->second) outgoing_.push_back(with_source_address(f, address_));
  } else {
    const bool transmitted = std::find(options_.transmitted_pgns.begin(), options_.transmitted_pgns.end(),
                                       request.pgn) != options_.transmitted_pgns.end();
    refuse(request, transmitted ? AckControl::kCannotRespond : AckControl::kNack);
    return;
  }
  ++counters_.requests_answered;
}

void J1939Node::send_heartbeat(std::int64_t now_ns) {
  const std::int64_t interval = options_.heartbeat_interval_ns;
  outgoing_.push_back(encode_n2k_heartbeat(interval, heartbeat_sequence_, controller_state_,
                                           N2kEquipmentStatus::kOperational, address_, kPriorityHeartbeat));
  heartbeat_sequence_ = static_cast<std::uint8_t>(heartbeat_sequence_ >= 252 ? 0 : heartbeat_sequence_ + 1);
  ++counters_.heartbeats_sent;
  heartbeat_due_ns_ = interval > 0 ? now_ns + interval : kNever;
}

void J1939Node::on_time(std::int64_t now_ns) {
  if (state_ == J1939AddressState::kClaiming && now_ns >= settle_deadline_ns_) {
    state_ = J1939AddressState::kClaimed;
    settle_deadline_ns_ = kNever;
    if (options_.heartbeat_interval_ns > 0) send_heartbeat(now_ns);
  }
  if (state_ == J1939AddressState::kClaimed && now_ns >= heartbeat_due_ns_) {
    send_heartbeat(now_ns);
  }
  if (state_ == J1939AddressState::kCannotClaim && now_ns >= cannot_claim_due_ns_) {
    outgoing_.push_back(encode_address_claimed(name_, kJ1939NullAddress));
    ++counters_.claims_sent;
    cannot_claim_due_ns_ = kNever;
  }
}

std::vector<CanFrame> J1939Node::take_outgoing() { return std::exchange(outgoing_, {}); }

void J1939Node::remember_message(std::uint32_t pgn, std::vector<CanFrame> frames) {
  last_messages_[pgn] = std::move(frames);
}

std::int64_t J1939Node::next_deadline_ns() const {
  return std::min({settle_deadline_ns_, heartbeat_due_ns_, cannot_claim_due_ns_});
}

}  // namespace sitepose::output
