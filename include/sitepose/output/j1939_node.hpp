#pragma once
// A J1939 / NMEA 2000 node's network side, as a state machine without I/O:
// frames from the bus and the time go in, frames to send come out. The
// SocketCAN sink (drivers/can/socketcan) runs it on its socket.
//
// * Address claim (J1939-81): claims the preferred address with its NAME and
//   waits claim_settle_ns before other traffic. A contest for its address is
//   decided by NAME, lower wins: the winner claims again; the loser, when
//   its NAME says arbitrary-address-capable, claims a free address of the
//   dynamic range, else (or when none is free) sends Cannot Claim (source
//   address 254) and stays silent, answering only Requests for Address
//   Claimed (after a pseudo-random 0-153 ms delay, as J1939-81 asks).
// * Request (PGN 59904) to the global address or its own: answers 60928
//   (Address Claimed), 126993 (Heartbeat), 126996 (Product Information) and
//   every PGN the application sent (its last message, remember_message());
//   a transmitted PGN without data yet gets Acknowledgement "cannot
//   respond", any other PGN a NACK - both only to a request addressed to
//   this node, never to a global one.
// * Heartbeat (PGN 126993) when the claim settles and every interval, with
//   the CAN controller's state.
// Not thread-safe: one thread (the sink's I/O thread) owns it.

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <vector>

#include "sitepose/output/can_frame.hpp"
#include "sitepose/output/j1939_network.hpp"
#include "sitepose/output/nmea2000.hpp"

namespace sitepose::output {

struct J1939NodeOptions {
  J1939Name name;
  std::uint8_t preferred_address = 0x1C;  // 0..253
  // Addresses tried after a lost contest (J1939-81 self-configurable range).
  std::uint8_t first_dynamic_address = 128;
  std::uint8_t last_dynamic_address = 247;
  std::int64_t claim_settle_ns = 250'000'000;          // J1939-81: 250 ms
  std::int64_t heartbeat_interval_ns = 60'000'000'000;  // NMEA 2000 default 60 s; 0 = none
  // PGNs the application sends (answered "cannot respond" before its first
  // message of that PGN).
  std::vector<std::uint32_t> transmitted_pgns;
  N2kProductInformation product;
};

// Fails naming the field: NAME fields, addresses (0..253, range ordered),
// settle time (0..10 s), heartbeat interval (0 or 0.01..655.32 s), product
// information strings.
Status check_j1939_node_options(const J1939NodeOptions& options);

enum class J1939AddressState {
  kStopped,      // not started, or the link is gone (start() again)
  kClaiming,     // claim sent, settle time running
  kClaimed,      // may send
  kCannotClaim,  // lost without a free address: silent
};
const char* to_string(J1939AddressState state);

struct J1939NodeCounters {
  std::uint64_t claims_sent = 0;      // Address Claimed and Cannot Claim frames
  std::uint64_t contests_won = 0;
  std::uint64_t contests_lost = 0;
  std::uint64_t address_changes = 0;  // moved to a dynamic address
  std::uint64_t name_conflicts = 0;   // a claim with this node's own NAME from elsewhere
  std::uint64_t requests_answered = 0;
  std::uint64_t requests_refused = 0;  // NACK or "cannot respond"
  std::uint64_t heartbeats_sent = 0;
};

class J1939Node {
 public:
  static constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();

  // `options` must pass check_j1939_node_options (checked: programmer error).
  explicit J1939Node(J1939NodeOptions options);

  // Claims the current address (the preferred one at first, the one it
  // moved to after a lost contest): at start and again after the link came
  // back (bus-off, interface down), since others may have claimed meanwhile.
  void start(std::int64_t now_ns);
  // The link is gone: nothing is sent until start().
  void stop();
  // A frame received from the bus.
  void on_frame(const CanFrame& frame, std::int64_t now_ns);
  // Timers: claim settling, heartbeat, a delayed Cannot Claim.
  void on_time(std::int64_t now_ns);
  // Frames to send now, in order (source address set); empties the list.
  std::vector<CanFrame> take_outgoing();
  // The application's last message of `pgn` (all its frames), re-sent when
  // a Request asks for it.
  void remember_message(std::uint32_t pgn, std::vector<CanFrame> frames);
  // For the heartbeat.
  void set_controller_state(N2kControllerState state) { controller_state_ = state; }

  bool may_transmit() const { return state_ == J1939AddressState::kClaimed; }
  J1939AddressState state() const { return state_; }
  // The address claimed or being claimed; kJ1939NullAddress when none.
  std::uint8_t address() const;
  std::uint64_t name() const { return name_; }
  // When on_time() next has work; kNever when no timer runs.
  std::int64_t next_deadline_ns() const;
  const J1939NodeCounters& counters() const { return counters_; }

 private:
  void claim(std::uint8_t address, std::int64_t now_ns);
  void on_address_claimed(const AddressClaim& claim, std::int64_t now_ns);
  void lose_contest(std::int64_t now_ns);
  void on_request(const Request& request, std::int64_t now_ns);
  void send_heartbeat(std::int64_t now_ns);
  bool is_for_me(std::uint8_t destination) const;
  std::optional<std::uint8_t> free_dynamic_address() const;
  void refuse(const Request& request, AckControl control);

  J1939NodeOptions options_;
  std::uint64_t name_;
  J1939AddressState state_ = J1939AddressState::kStopped;
  std::uint8_t address_;
  std::int64_t settle_deadline_ns_ = kNever;
  std::int64_t heartbeat_due_ns_ = kNever;
  std::int64_t cannot_claim_due_ns_ = kNever;
  std::uint8_t heartbeat_sequence_ = 0;
  std::uint8_t product_sequence_ = 0;
  N2kControllerState controller_state_ = N2kControllerState::kErrorActive;
  std::map<std::uint8_t, std::uint64_t> claimed_by_others_;  // address -> NAME
  std::map<std::uint32_t, std::vector<CanFrame>> last_messages_;
  std::vector<CanFrame> outgoing_;
  J1939NodeCounters counters_;
};

}  // namespace sitepose::output
