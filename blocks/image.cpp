// Serialisation and verification of task images (see image.h).
#include "blocks/image.h"

#include <cstddef>

#include <cmath>
#include <cstring>
#include <string>

#include "common/capacities.h"

namespace rtplc {
namespace {

constexpr uint64_t align8(uint64_t n) { return (n + 7) & ~uint64_t{7}; }

std::string at_instr(uint32_t i, const char* what) {
  return "instruction " + std::to_string(i) + ": " + what;
}

bool finite_all(std::span<const double> v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

}  // namespace

uint64_t fnv1a64(std::string_view s) {
  uint64_t h = 1469598103934665603ull;
  for (char c : s) {
    h ^= static_cast<uint8_t>(c);
    h *= 1099511628211ull;
  }
  return h;
}

std::string channel_key(BindingDir dir, IoGroup group, char device, uint32_t p, uint32_t d, uint32_t c) {
  // A quality binding names the input channel it reads the quality of.
  std::string k = dir == BindingDir::kInput || dir == BindingDir::kQuality ? "in/"
                  : dir == BindingDir::kOutput                            ? "out/"
                                                                          : "sp/";
  k += io_group_name(group);
  if (device != 0) k += device;
  k += '/';
  if (dir != BindingDir::kSetpoint) k += "p" + std::to_string(p) + ".";
  k += "d" + std::to_string(d) + ".c" + std::to_string(c);
  return k;
}

std::string binding_key(const Binding& b) { return channel_key(b.dir, b.group, b.device, b.p, b.d, b.c); }

uint32_t ImageBuilder::add_string(std::string_view s) {
  auto it = interned_.find(std::string(s));
  if (it != interned_.end()) return it->second;
  auto off = static_cast<uint32_t>(strings_.size());
  strings_.append(s);
  strings_.push_back('\0');
  interned_.emplace(std::string(s), off);
  return off;
}

Result<TaskImage> ImageBuilder::finish() const {
  ImageHeader h{};
  std::memcpy(h.magic, kImageMagic, sizeof h.magic);
  h.version = kImageVersion;
  h.header_size = sizeof(ImageHeader);
  h.source_hash = source_hash;
  h.period_ns = period_ns;
  h.dt = dt;
  h.name = name;
  h.n_instr = static_cast<uint32_t>(code.size());
  h.n_runs = static_cast<uint32_t>(runs.size());
  h.n_values = n_values;
  h.n_state = n_state;
  h.n_params = static_cast<uint32_t>(params.size());
  h.n_raw_params = static_cast<uint32_t>(raw_params.size());
  h.n_bindings = static_cast<uint32_t>(bindings.size());
  h.n_io_in = n_io_in;
  h.n_io_out = n_io_out;
  std::string pool = strings_.empty() ? std::string(1, '\0') : strings_;
  h.n_strings = static_cast<uint32_t>(pool.size());

  uint64_t off = align8(sizeof(ImageHeader));
  auto place = [&off](uint64_t bytes) {
    uint64_t at = off;
    off = align8(off + bytes);
    return at;
  };
  h.off_instr = place(code.size() * sizeof(Instr));
  h.off_runs = place(runs.size() * sizeof(Run));
  h.off_params = place(params.size() * sizeof(double));
  h.off_raw_params = place(raw_params.size() * sizeof(double));
  h.off_bindings = place(bindings.size() * sizeof(Binding));
  h.off_blocks = place(blocks.size() * sizeof(BlockInfo));
  h.off_strings = place(pool.size());
  h.total_size = off;

  TaskImage img;
  img.size_ = off;
  img.words_ = std::make_unique<uint64_t[]>(off / 8);  // zero-filled: padding is deterministic
  auto* base = reinterpret_cast<std::byte*>(img.words_.get());
  auto copy = [base](uint64_t at, const void* src, size_t n) {
    if (n > 0) std::memcpy(base + at, src, n);
  };
  copy(0, &h, sizeof h);
  copy(h.off_instr, code.data(), code.size() * sizeof(Instr));
  copy(h.off_runs, runs.data(), runs.size() * sizeof(Run));
  copy(h.off_params, params.data(), params.size() * sizeof(double));
  copy(h.off_raw_params, raw_params.data(), raw_params.size() * sizeof(double));
  copy(h.off_bindings, bindings.data(), bindings.size() * sizeof(Binding));
  copy(h.off_blocks, blocks.data(), blocks.size() * sizeof(BlockInfo));
  copy(h.off_strings, pool.data(), pool.size());
  const uint32_t check = image_body_check(img.bytes());
  std::memcpy(base + offsetof(ImageHeader, body_check), &check, sizeof check);

  Result<void> v = verify_image(img.bytes());
  if (!v) return make_error("internal error, the compiler built an invalid image: " + v.error());
  return img;
}

Result<TaskImage> TaskImage::from_bytes(std::span<const std::byte> bytes) {
  if (Result<void> v = verify_image(bytes); !v) return make_error(v.error());
  TaskImage img;
  img.size_ = bytes.size();
  img.words_ = std::make_unique<uint64_t[]>(align8(bytes.size()) / 8);
  std::memcpy(img.words_.get(), bytes.data(), bytes.size());
  return img;
}

uint32_t image_body_check(std::span<const std::byte> bytes) {
  if (bytes.size() <= sizeof(ImageHeader)) return 0;
  const uint64_t h = fnv1a64(std::string_view(reinterpret_cast<const char*>(bytes.data()) + sizeof(ImageHeader),
                                              bytes.size() - sizeof(ImageHeader)));
  return static_cast<uint32_t>(h ^ (h >> 32));
}

Result<void> verify_image(std::span<const std::byte> bytes) {
  if (bytes.size() < sizeof(ImageHeader)) return make_error("image shorter than its header");
  if (reinterpret_cast<uintptr_t>(bytes.data()) % 8 != 0) {
    return make_error("image is not 8-byte aligned");
  }
  ImageHeader h;
  std::memcpy(&h, bytes.data(), sizeof h);
  if (std::memcmp(h.magic, kImageMagic, sizeof h.magic) != 0) return make_error("bad magic");
  if (h.version != kImageVersion) {
    return make_error("image version " + std::to_string(h.version) + ", this runtime reads " +
                      std::to_string(kImageVersion));
  }
  if (h.header_size != sizeof(ImageHeader)) return make_error("bad header size");
  if (h.total_size != bytes.size()) return make_error("size field does not match the buffer");
  if (!(h.dt > 0) || !std::isfinite(h.dt) || h.period_ns <= 0) return make_error("bad period");
  if (h.n_instr > kMaxBlocks) return make_error("more instructions than RTPLC_MAX_BLOCKS");
  if (h.n_bindings > kMaxChannels) return make_error("more bindings than RTPLC_MAX_CHANNELS");

  auto section_ok = [&](uint64_t off, uint64_t count, uint64_t elem) {
    if (off % 8 != 0 || off < sizeof(ImageHeader) || off > bytes.size()) return false;
    if (elem != 0 && count > (bytes.size() - off) / elem) return false;
    return true;
  };
  if (!section_ok(h.off_instr, h.n_instr, sizeof(Instr)) ||
      !section_ok(h.off_runs, h.n_runs, sizeof(Run)) ||
      !section_ok(h.off_params, h.n_params, sizeof(double)) ||
      !section_ok(h.off_raw_params, h.n_raw_params, sizeof(double)) ||
      !section_ok(h.off_bindings, h.n_bindings, sizeof(Binding)) ||
      !section_ok(h.off_blocks, h.n_instr, sizeof(BlockInfo)) ||
      !section_ok(h.off_strings, h.n_strings, 1)) {
    return make_error("a section lies outside the image");
  }
  if (h.n_strings == 0 || static_cast<char>(bytes[h.off_strings + h.n_strings - 1]) != '\0') {
    return make_error("string pool is not NUL-terminated");
  }
  auto str_ok = [&](uint32_t off) { return off < h.n_strings; };
  if (!str_ok(h.name)) return make_error("program name out of bounds");

  auto sec = [&](uint64_t off) { return bytes.data() + off; };
  std::span<const Instr> code(reinterpret_cast<const Instr*>(sec(h.off_instr)), h.n_instr);
  std::span<const Run> runs(reinterpret_cast<const Run*>(sec(h.off_runs)), h.n_runs);
  std::span<const double> params(reinterpret_cast<const double*>(sec(h.off_params)), h.n_params);
  std::span<const double> raw(reinterpret_cast<const double*>(sec(h.off_raw_params)),
                              h.n_raw_params);
  std::span<const Binding> binds(reinterpret_cast<const Binding*>(sec(h.off_bindings)),
                                 h.n_bindings);
  std::span<const BlockInfo> infos(reinterpret_cast<const BlockInfo*>(sec(h.off_blocks)),
                                   h.n_instr);

  if (!finite_all(params) || !finite_all(raw)) return make_error("a parameter is not finite");

  // The arena sizes must be exactly what the code needs: an image cannot ask
  // for more memory than its instructions use (each value slot and output has
  // one writer, each input one or more readers, the state its blocks' sum).
  {
    uint64_t writers = 0, stores = 0, loads = 0;
    for (const Instr& in : code) {
      if (static_cast<uint8_t>(in.op) >= kOpCount) break;  // reported below
      stores += op_is_store(in.op);
      loads += op_is_load(in.op);
      if (op_writes_value(in.op)) {
        // A string result takes 1 + cap slots (its cap checked below).
        const double cap = op_output_string(in.op) && in.param < h.n_params ? params[in.param] : 0;
        writers += 1 + (cap >= 0 && cap <= kMaxStringLength ? static_cast<uint64_t>(cap) : 0);
      }
    }
    // Outputs may leave holes (a hot-swapped program keeps the running layout),
    // bounded by the channel capacity.
    if (h.n_values != writers || h.n_io_out < stores || h.n_io_out > stores + kMaxChannels ||
        h.n_io_in > loads) {
      return make_error("arena sizes do not match the code");
    }
  }
  uint64_t state_needed = 0;
  // Each value slot has exactly one writer; each output-buffer entry too.
  // (value_writer: the opcode that writes each slot, kNoWriter before one does;
  // a Set may only write a slot whose writer is a Var.)
  constexpr uint8_t kNoWriter = 0xFF;
  static_assert(kOpCount < kNoWriter);
  std::vector<uint8_t> value_writer(h.n_values, kNoWriter);
  // The slots after a string's length (its characters) belong to it too; the
  // heads' caps, so a string input can be checked to read a whole string.
  constexpr uint8_t kStringBody = 0xFE;
  static_assert(kOpCount < kStringBody);
  std::vector<uint32_t> string_cap(h.n_values, 0);
  std::vector<uint8_t> out_written(h.n_io_out, 0);
  for (uint32_t i = 0; i < h.n_instr; ++i) {
    const Instr& in = code[i];
    if (static_cast<uint8_t>(in.op) >= kOpCount) return make_error(at_instr(i, "bad opcode"));
    const uint32_t n_in = op_input_count(in.op);
    if (in.n_in != n_in) return make_error(at_instr(i, "wrong input count for its opcode"));
    if (op_is_load(in.op)) {
      if (in.in[0] >= h.n_io_in) return make_error(at_instr(i, "input-buffer index out of range"));
    } else {
      for (uint32_t k = 0; k < n_in; ++k) {
        if (in.in[k] >= h.n_values) return make_error(at_instr(i, "input slot out of range"));
      }
    }
    uint32_t np = op_param_count(in.op);
    if (in.param > h.n_params || np > h.n_params - in.param) {
      return make_error(at_instr(i, "parameters out of range"));
    }
    const double* p = np > 0 ? params.data() + in.param : nullptr;
    uint32_t width = 1;
    if (op_output_string(in.op) || in.op == Op::SSet) {
      if (!(p[0] >= 0 && p[0] <= kMaxStringLength && p[0] == std::floor(p[0]))) {
        return make_error(at_instr(i, "string length out of range"));
      }
      if (in.op != Op::SSet) width = op_value_width(in.op, p);
    }
    if (in.op == Op::SConst) {
      np = instr_param_count(in.op, p);
      if (np > h.n_params - in.param) return make_error(at_instr(i, "string literal out of range"));
      for (uint32_t k = 1; k < np; ++k) {
        if (!(p[k] >= 0 && p[k] <= 65535 && p[k] == std::floor(p[k]))) {
          return make_error(at_instr(i, "string literal holds a bad character code"));
        }
      }
    }
    if ((in.op == Op::SCmp && !(p[0] >= 0 && p[0] <= 5 && p[0] == std::floor(p[0]))) ||
        (in.op == Op::SCopy && !(p[1] == 0 || p[1] == 1)) ||
        (in.op == Op::SFmt && !(p[1] >= 0 && p[1] < kStringFormats && p[1] == std::floor(p[1]) &&
                                (p[2] == 0 || p[2] == 1))) ||
        (in.op == Op::SParse && !(p[0] >= 0 && p[0] < kStringFormats && p[0] == std::floor(p[0]) &&
                                  (p[1] == 0 || p[1] == 1)))) {
      return make_error(at_instr(i, "string operation code out of range"));
    }
    if (op_is_store(in.op)) {
      if (in.out >= h.n_io_out) return make_error(at_instr(i, "output-buffer index out of range"));
      if (out_written[in.out]++) return make_error(at_instr(i, "second writer of an output"));
    } else if (in.op == Op::Set) {
      if (in.out >= h.n_values) return make_error(at_instr(i, "variable slot out of range"));
    } else if (in.op == Op::Put) {
      // It writes through its table, checked with the parameters below.
    } else if (op_is_branch(in.op)) {
      // `out` is a run index, checked with the runs below.
    } else if (in.op == Op::SSet) {
      if (in.out >= h.n_values) return make_error(at_instr(i, "variable slot out of range"));
    } else {
      if (in.out >= h.n_values || width > h.n_values - in.out) {
        return make_error(at_instr(i, "output slot out of range"));
      }
      for (uint32_t w = 0; w < width; ++w) {
        if (value_writer[in.out + w] != kNoWriter) return make_error(at_instr(i, "second writer of a value slot"));
        value_writer[in.out + w] = w == 0 ? static_cast<uint8_t>(in.op) : kStringBody;
      }
      if (op_output_string(in.op)) string_cap[in.out] = width - 1;
    }
    if (in.op == Op::Pick || in.op == Op::Put) {
      // n, lo, then n value slots: every one a whole number inside the arena.
      if (!(p[0] >= 1 && p[0] <= kMaxPickTable && p[0] == std::floor(p[0])) || p[1] != std::floor(p[1]) ||
          std::fabs(p[1]) > 1e15) {
        return make_error(at_instr(i, "index table header invalid"));
      }
      np = instr_param_count(in.op, p);
      if (np > h.n_params - in.param) return make_error(at_instr(i, "index table out of range"));
      for (uint32_t k = 2; k < np; ++k) {
        if (!(p[k] >= 0 && p[k] < h.n_values && p[k] == std::floor(p[k]))) {
          return make_error(at_instr(i, "index table names a slot out of range"));
        }
      }
    }
    if (in.op == Op::Dely) {
      if (!(p[0] >= 0) || p[0] > static_cast<double>(kMaxDelaySamples) || p[0] != std::floor(p[0])) {
        return make_error(at_instr(i, "dely sample count invalid"));
      }
    }
    if (in.op == Op::Lim && !(p[0] <= p[1])) return make_error(at_instr(i, "lim lo > hi"));
    const uint32_t ns = op_state_size(in.op, p);
    if (in.state > h.n_state || ns > h.n_state - in.state) {
      return make_error(at_instr(i, "state out of range"));
    }
    state_needed += ns;
    const BlockInfo& bi = infos[i];
    if (!str_ok(bi.name) || !str_ok(bi.block)) return make_error(at_instr(i, "bad debug string"));
    if (bi.raw_param > h.n_raw_params || bi.raw_count > h.n_raw_params - bi.raw_param) {
      return make_error(at_instr(i, "literal parameters out of range"));
    }
    if (bi.text_index >= h.n_instr) return make_error(at_instr(i, "bad text index"));
  }
  if (state_needed != h.n_state) return make_error("state size does not match the code");
  // A Set writes a variable's home and nothing else: never a block's result,
  // which every reader of that block trusts to be what the block computed.
  for (uint32_t i = 0; i < h.n_instr; ++i) {
    // A string input reads a whole string: the head of a string result (so
    // its length was written by a string opcode, within that result's slots).
    const Instr& in = code[i];
    for (uint32_t k = 0; k < in.n_in && !op_is_load(in.op); ++k) {
      if (op_input_is_string(in.op, k) != (value_writer[in.in[k]] < kOpCount &&
                                           op_output_string(static_cast<Op>(value_writer[in.in[k]])))) {
        return make_error(at_instr(i, op_input_is_string(in.op, k) ? "a string input reads no string"
                                                                   : "a number input reads a string"));
      }
    }
    if (in.op == Op::SSet && (value_writer[in.out] != static_cast<uint8_t>(Op::SVar) ||
                              string_cap[in.out] != static_cast<uint32_t>(params[in.param]))) {
      return make_error(at_instr(i, "an SSet writes a slot that is not a string variable's of its length"));
    }
    if (code[i].op == Op::Set && value_writer[code[i].out] != static_cast<uint8_t>(Op::Var)) {
      return make_error(at_instr(i, "a Set writes a slot that is not a variable's"));
    }
    if (code[i].op == Op::Put) {
      const double* p = params.data() + code[i].param;
      const uint32_t n = static_cast<uint32_t>(p[0]);
      for (uint32_t k = 0; k < n; ++k) {
        if (value_writer[static_cast<uint32_t>(p[2 + k])] != static_cast<uint8_t>(Op::Var)) {
          return make_error(at_instr(i, "a Put writes a slot that is not a variable's"));
        }
      }
    }
  }
  // Runs cover the code exactly once, in order, and each holds one opcode.
  uint32_t next = 0;
  for (uint32_t r = 0; r < h.n_runs; ++r) {
    const Run& run = runs[r];
    if (run.begin != next || run.end <= run.begin || run.end > h.n_instr) {
      return make_error("run " + std::to_string(r) + " does not continue the previous one");
    }
    for (uint32_t i = run.begin; i < run.end; ++i) {
      if (code[i].op != run.op) return make_error("run " + std::to_string(r) + " mixes opcodes");
    }
    if (run.flags & ~(kRunAffine | kRunUniformParams)) return make_error("bad run flags");
    if (op_is_branch(run.op)) {
      // Alone in its run, its target a run boundary: forward for Jmp/Jz/Jnz
      // (up to n_runs, the end of the cycle), backward or onto itself for
      // Loop, the only edge that can repeat code and the one the budget counts.
      const uint32_t target = code[run.begin].out;
      if (run.end - run.begin != 1) return make_error("run " + std::to_string(r) + ": a branch shares its run");
      const bool ok = run.op == Op::Loop ? target <= r : target > r && target <= h.n_runs;
      if (!ok) return make_error("run " + std::to_string(r) + ": branch target out of range");
    }
    if ((run.flags & kRunAffine) && (op_is_branch(run.op) || run.op == Op::Set || run.op == Op::Var ||
                                     run.op == Op::Pick || run.op == Op::Put || op_is_string(run.op))) {
      return make_error("run " + std::to_string(r) + ": this opcode cannot be affine");
    }
    if (run.flags & kRunAffine) {
      // The executor trusts these formulas instead of the instructions: check
      // every element (the instructions themselves were bounds-checked above).
      const Op op = run.op;
      if (op == Op::Dely) {
        return make_error("run " + std::to_string(r) + ": this opcode cannot be affine");
      }
      const bool same_array = !op_is_load(op) && !op_is_store(op);
      const uint32_t n = run.end - run.begin, n_in = op_is_load(op) ? 1 : op_input_count(op);
      const uint32_t np = op_param_count(op), ns = op_state_size(op, nullptr);
      for (uint32_t j = 0; j < n; ++j) {
        const Instr& in = code[run.begin + j];
        bool ok = in.out == run.out + j && in.state == run.state + j * ns &&
                  in.param == run.param + j * np;
        for (uint32_t k = 0; k < n_in; ++k) ok = ok && in.in[k] == run.in[k] + j;
        if (ok && (run.flags & kRunUniformParams)) {
          for (uint32_t k = 0; k < np; ++k) ok = ok && params[in.param + k] == params[run.param + k];
        }
        if (!ok) return make_error("run " + std::to_string(r) + " is not affine as it claims");
      }
      for (uint32_t k = 0; k < n_in && same_array; ++k) {
        if (run.in[k] < run.out + n && run.out < run.in[k] + n) {
          return make_error("run " + std::to_string(r) + ": affine operands overlap its output");
        }
      }
    } else if (run.flags & kRunUniformParams) {
      return make_error("run " + std::to_string(r) + ": uniform parameters without affine layout");
    }
    next = run.end;
  }
  if (next != h.n_instr) return make_error("runs do not cover every instruction");
  for (uint32_t b = 0; b < h.n_bindings; ++b) {
    const Binding& bd = binds[b];
    const bool out = bd.dir == BindingDir::kOutput;
    if (bd.dir > BindingDir::kQuality) return make_error("binding " + std::to_string(b) + ": unknown direction");
    if (bd.io_index >= (out ? h.n_io_out : h.n_io_in) || bd.instr >= h.n_instr ||
        !str_ok(bd.label) || !std::isfinite(bd.init)) {
      return make_error("binding " + std::to_string(b) + " out of range");
    }
  }
  return {};
}

}  // namespace rtplc
