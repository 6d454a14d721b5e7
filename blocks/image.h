// The compiled task image (spec fbd-language.md, "The compiled form").
//
// One contiguous, position-independent byte buffer: a header, then sections that
// refer to each other only by index — never by pointer — so an image can be
// checked before it runs (verify_image: every index in bounds, every parameter
// present), saved to a file, copied into shared memory and published to a running
// task with one atomic pointer store.
//
//   header | Instr[n_instr] | Run[n_runs] | prepared params | literal params |
//   Binding[n_bindings] | BlockInfo[n_instr] | string pool
//
// Instructions are stored in *schedule* order: the compiler groups independent
// blocks of the same opcode into runs so the executor dispatches once per run.
// The semantics are those of textual order (BlockInfo::text_index keeps it): the
// schedule only reorders blocks with no data dependence between them, and every
// read of a later-or-same block reads last cycle's value exactly as in text order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "blocks/ops.h"
#include "blocks/registry.h"
#include "common/result.h"

namespace rtplc {

inline constexpr char kImageMagic[8] = {'R', 'T', 'P', 'L', 'C', 'I', 'M', 'G'};
inline constexpr uint32_t kImageVersion = 4;  // 3: body_check (was reserved); 4: timers keep their last call's cycle

// Instruction flags.
inline constexpr uint16_t kInstrDelayed0 = 1u << 0;  // input i reads last cycle's value
inline constexpr uint16_t kInstrDelayed1 = 1u << 1;
inline constexpr uint16_t kInstrDelayed2 = 1u << 2;

struct Instr {
  Op op;
  uint8_t n_in;
  uint16_t flags;
  uint32_t out;    // value slot written; for stores, the output-buffer index
  uint32_t in[3];  // value slots read; for loads, in[0] is the input-buffer index
  uint32_t param;  // first prepared parameter in the pool
  uint32_t state;  // first state double
  uint32_t reserved;
};
static_assert(sizeof(Instr) == 32);

// Run flags. An *affine* run's operands are laid out so that element j (the
// instruction begin + j) uses out + j, in[k] + j, param + j*P (or param itself
// when the parameters are uniform) and state + j*S, where P and S are the
// opcode's parameter and state sizes. The executor then walks plain arrays —
// no index loads, loops the compiler can vectorise. The verifier checks that
// every instruction of an affine run matches these formulas.
inline constexpr uint8_t kRunAffine = 1u << 0;
inline constexpr uint8_t kRunUniformParams = 1u << 1;

struct Run {
  Op op;
  uint8_t flags;
  uint16_t pad;
  uint32_t begin;  // [begin, end) instruction indices, all with this opcode
  uint32_t end;
  uint32_t out;    // affine runs only: bases of the operand arrays
  uint32_t in[3];
  uint32_t param;
  uint32_t state;
};
static_assert(sizeof(Run) == 36);

// kQuality: the `good` block's load of the quality of an input channel (the
// same channel, key and label as that input's kInput binding); the runtime
// fills its input slot with 1 (good or forced) or 0 (bad, stale, unfed).
enum class BindingDir : uint8_t { kInput, kSetpoint, kOutput, kQuality };

// Binding flags.
// The channel of an HMI variable (Beremiz SVGHMI's HMI_INT...: docs/st.md,
// "HMI variables"): the runtime marks it so for the web console.
inline constexpr uint32_t kBindingHmi = 1u << 0;

// One I/O channel the task reads or writes, addressed the seed's way (p, d, c).
struct Binding {
  BindingDir dir;
  IoGroup group;
  Kind kind;
  char device;        // PLC device letter (X/Y/M/R), 'P' for a pulse input, 0 otherwise
  uint16_t p;         // processor (0 for set-points)
  uint16_t d;         // module / device
  uint32_t c;         // channel
  uint32_t io_index;  // index in the task's input buffer (inputs, set-points) or output buffer
  uint32_t instr;     // the load/store instruction (schedule index)
  uint32_t label;     // string offset
  uint32_t line;      // source line of the block
  uint32_t flags;
  uint32_t reserved;
  double init;        // set-points: initial value
};
static_assert(sizeof(Binding) == 48);

// Debug and migration record of one instruction.
struct BlockInfo {
  uint64_t key;         // stable identity: hash of `name`; hot swap matches (key, op)
  uint32_t name;        // string offset: "F10", or "F10.M4" inside a macro expansion
  uint32_t block;       // string offset: the block's name as written ("pid", "deriv")
  uint32_t line;        // statement position
  uint32_t col;
  uint32_t call_line;   // outermost macro call site, 0 at top level
  uint32_t text_index;  // position in textual (semantic) order
  uint32_t raw_param;   // first literal parameter
  uint32_t raw_count;   // number of literal parameters
};
static_assert(sizeof(BlockInfo) == 40);

struct ImageHeader {
  char magic[8];
  uint32_t version;
  uint32_t header_size;
  uint64_t total_size;
  uint64_t source_hash;  // FNV-1a of the source text
  int64_t period_ns;
  double dt;             // seconds; parameters were prepared for this period
  uint32_t name;         // string offset: program name
  uint32_t n_instr;
  uint32_t n_runs;
  uint32_t n_values;
  uint32_t n_state;
  uint32_t n_params;
  uint32_t n_raw_params;
  uint32_t n_bindings;
  uint32_t n_io_in;
  uint32_t n_io_out;
  uint32_t n_strings;    // bytes in the string pool
  uint32_t body_check;   // FNV-1a of the bytes after the header, folded to 32 bits (image_body_check)
  uint64_t off_instr;
  uint64_t off_runs;
  uint64_t off_params;
  uint64_t off_raw_params;
  uint64_t off_bindings;
  uint64_t off_blocks;
  uint64_t off_strings;
};

// An immutable, verified image. Cheap to move; the bytes are 8-byte aligned.
class TaskImage {
 public:
  TaskImage() = default;

  // Verifies `bytes` and copies them into a new image.
  static Result<TaskImage> from_bytes(std::span<const std::byte> bytes);

  std::span<const std::byte> bytes() const { return {data(), size_}; }
  bool empty() const { return size_ == 0; }

  const ImageHeader& header() const { return *reinterpret_cast<const ImageHeader*>(data()); }
  std::span<const Instr> code() const { return section<Instr>(header().off_instr, header().n_instr); }
  std::span<const Run> runs() const { return section<Run>(header().off_runs, header().n_runs); }
  std::span<const double> params() const {
    return section<double>(header().off_params, header().n_params);
  }
  std::span<const double> raw_params() const {
    return section<double>(header().off_raw_params, header().n_raw_params);
  }
  std::span<const Binding> bindings() const {
    return section<Binding>(header().off_bindings, header().n_bindings);
  }
  std::span<const BlockInfo> blocks() const {
    return section<BlockInfo>(header().off_blocks, header().n_instr);
  }
  // A NUL-terminated string from the pool (verified in bounds).
  const char* str(uint32_t offset) const {
    return reinterpret_cast<const char*>(data() + header().off_strings + offset);
  }

  double period_s() const { return header().dt; }
  std::string_view name() const { return str(header().name); }

 private:
  friend class ImageBuilder;
  const std::byte* data() const { return reinterpret_cast<const std::byte*>(words_.get()); }
  template <typename T>
  std::span<const T> section(uint64_t off, uint32_t n) const {
    return {reinterpret_cast<const T*>(data() + off), n};
  }

  std::unique_ptr<uint64_t[]> words_;
  size_t size_ = 0;
};

// Checks an image before anything runs it: header, section bounds and alignment,
// every instruction's opcode, operand indices, parameter and state ranges, run
// coverage, binding and debug indices, and string termination.
Result<void> verify_image(std::span<const std::byte> bytes);

// The check value of an image's body (everything after the header). The
// compiler stores it in the header; a loader of image *files* compares it, so
// a byte changed after compiling (a disk, a copy, a hand) is refused as
// damaged, whatever the structural verifier would make of it. verify_image
// itself does not look at it: the structure is checked on its own merits.
uint32_t image_body_check(std::span<const std::byte> bytes);

// Assembles an image from the compiler's tables (lang/compiler.cpp is the user).
class ImageBuilder {
 public:
  uint32_t add_string(std::string_view s);  // deduplicated

  std::vector<Instr> code;
  std::vector<Run> runs;
  std::vector<double> params;
  std::vector<double> raw_params;
  std::vector<Binding> bindings;
  std::vector<BlockInfo> blocks;
  uint32_t n_values = 0;
  uint32_t n_state = 0;
  uint32_t n_io_in = 0;
  uint32_t n_io_out = 0;
  uint64_t source_hash = 0;
  int64_t period_ns = 0;
  double dt = 0;
  uint32_t name = 0;

  // Serialises and verifies. A verification failure here is a compiler bug.
  Result<TaskImage> finish() const;

 private:
  std::string strings_;
  std::unordered_map<std::string, uint32_t> interned_;
};

uint64_t fnv1a64(std::string_view s);

// A channel's identity, the same in every image and in the process image:
// "in/DIO/p0.d0.c0", "out/PLCY/p1.d0.c3", "sp/SETP/d0.c2". The direction is part of
// it: an input and an output at one address are two channels.
std::string binding_key(const Binding& b);
// The same key from its parts, for drivers that name channels without a
// Binding (`device` 0 when the group has none).
std::string channel_key(BindingDir dir, IoGroup group, char device, uint32_t p, uint32_t d, uint32_t c);

}  // namespace rtplc
