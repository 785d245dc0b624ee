// Allocation-free decoding of measured_state_t: the LCM encoding read straight into a StateSlot.
//
// The decoder the loop's thread may run (the event-driven hand-off: the loop takes each state from
// the receive process's ring itself, rx_isolated.h). The generated decoder (StateDecoder, codec.h)
// decodes into a message object whose strings and vectors it resizes, so a name of a new length (a
// hostile sender's, or a sender alternating full and joints-only states) allocates; this one never
// does: it walks the bytes once with every count and length checked against the bytes left (and the
// counts against the scene's sizes), then reads names as byte ranges, looked up in tables of the
// scene's names built at start-up, and the numbers (big-endian IEEE doubles) into the slot's Eigen
// vectors, sized by the slot's owner. A message it refuses gets the reason the generated decoder
// gives, checked in the same order (tests/io/codec/direct_decoder_test.cc compares the two on valid,
// mutated and hostile messages; tests/fuzz/fuzz_test.cc does so on the fuzzer's inputs). No
// allocation, no exception, no logging after construction.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "service/dynamics/state_fit.h"
#include "service/dynamics/system.h"
#include "service/io/codec/messages.h"

namespace coopdyn::io {

// A scene's names, looked up by their bytes: sorted once, found by binary search over byte
// comparisons (no std::string made). A name given twice in the list is found at its first index.
class NameTable {
 public:
  explicit NameTable(const std::vector<std::string>& names);
  int find(const char* p, int len) const;  // the index in the list given, -1 if not there

 private:
  std::vector<std::pair<std::string, int>> sorted_;
};

class DirectStateDecoder {
 public:
  explicit DirectStateDecoder(const System& sys);  // allocates (start-up)
  // As StateDecoder::decode (codec.h): validates a measured_state_t into out (q, v, tau sized nq, nv,
  // nv; has_wrench and wrench sized to the scene's wrench outputs, else sized here once). On a reject,
  // out is partly written and must not be used.
  Reject decode(const void* data, int len, StateSlot& out);
  const StateFitPlan& plan() const { return plan_; }

 private:
  Reject omitted(const std::vector<unsigned char>& seen, const std::vector<unsigned char>& fit_mask,
                 const std::vector<unsigned char>& pseudo_mask, bool fittable, int n_fit, bool* fit) const;
  const System& sys_;
  StateFitPlan plan_;
  NameTable q_names_, v_names_, wrench_names_;
  std::vector<unsigned char> seen_q_, seen_v_;
  std::vector<unsigned char> fit_q_mask_, fit_v_mask_, pseudo_q_mask_, pseudo_v_mask_;
};

}  // namespace coopdyn::io
