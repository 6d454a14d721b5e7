// Native code for a task image: generation, compilation and loading (see
// native.h for the design, docs/st.md "Native code" for the user's side).
#include "blocks/native.h"

#include <dirent.h>
#include <dlfcn.h>
#include <sched.h>
#include <signal.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string_view>
#include <vector>

#include "blocks/ops.h"
#include "common/files.h"

extern char** environ;

namespace rtplc {

namespace native_kit {  // build/blocks/native_kit.cpp (cmake/EmbedText.cmake)
extern const char kIntMath[];
extern const char kKernels[];
extern const char kAbi[];
}  // namespace native_kit

namespace {

// Runs longer than this that the compiler proved affine stay with the
// interpreter, whose loops over them are vectorised; translated one instruction
// at a time they would be slower, not faster.
constexpr uint32_t kLongAffineRun = 8;

struct KernelShape {
  const char* name;
  uint32_t np, ns;
};

// The kernel opcodes' names and sizes, indexed by opcode (name null: not a kernel).
const KernelShape* kernel_shape(Op op) {
  static const auto table = [] {
    std::vector<KernelShape> t(kOpCount, KernelShape{nullptr, 0, 0});
#define RTPLC_SHAPE(name, NP, NS) t[static_cast<uint8_t>(Op::name)] = KernelShape{#name, NP, NS};
    RTPLC_KERNEL_OPS(RTPLC_SHAPE)
#undef RTPLC_SHAPE
    return t;
  }();
  const KernelShape& s = table[static_cast<uint8_t>(op)];
  return s.name != nullptr ? &s : nullptr;
}

// The embedded headers without their `#pragma once`, which only a header may hold.
std::string kit_text(const char* text) {
  std::string out;
  std::istringstream in{std::string(text)};
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("#pragma once", 0) == 0) continue;
    out += line;
    out += '\n';
  }
  return out;
}

// A double as C++ source, exactly (hexadecimal floating point).
std::string literal(double v) {
  if (std::isnan(v)) return "__builtin_nan(\"\")";
  if (std::isinf(v)) return v > 0 ? "__builtin_inf()" : "(-__builtin_inf())";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

std::string hex64(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// The tag the library carries, compared when it is loaded: the interface's
// version and the image it was made from.
std::string native_tag(uint64_t fingerprint) {
  return "rtplc-native abi " + std::to_string(RTPLC_NATIVE_ABI) + " image " + hex64(fingerprint);
}

// Per run index: how many branches pass over it without landing on it. A
// forward jump s -> t passes s+1 .. t-1 (those runs may not run this cycle);
// with `loops`, a backward Loop s -> t passes t+1 .. s too (code it repeats).
std::vector<int32_t> passed_over(const TaskImage& image, bool loops) {
  const uint32_t n_runs = image.header().n_runs;
  const auto runs = image.runs();
  const auto code = image.code();
  std::vector<int32_t> count(n_runs + 1, 0);  // differences first, then their sums
  for (uint32_t s = 0; s < n_runs; ++s) {
    if (!op_is_branch(runs[s].op)) continue;
    const uint32_t t = code[runs[s].begin].out;
    if (t <= s && !loops) continue;
    const uint32_t lo = t > s ? s + 1 : t + 1, hi = t > s ? t - 1 : s;
    if (lo <= hi) {
      ++count[lo];
      --count[hi + 1];
    }
  }
  for (uint32_t i = 1; i <= n_runs; ++i) count[i] += count[i - 1];
  count.pop_back();
  return count;
}

// Writes the code of one run into `body`; tables it needs go to `globals`.
class Translator {
 public:
  Translator(const TaskImage& image, std::string& globals, std::string& body)
      : img_(image), code_(image.code()), params_(image.params()), globals_(globals), body_(body) {
    find_constant_slots();
  }

  // Returns true when the run was translated, false when handed back.
  bool run(uint32_t ri, const Run& r) {
    run_ = ri;
    const Op op = r.op;
    const uint32_t n = r.end - r.begin;
    if (const KernelShape* k = kernel_shape(op); k != nullptr) {
      const bool affine = (r.flags & kRunAffine) != 0;
      if (affine && n > kLongAffineRun) return interpret(ri);
      for (uint32_t j = 0; j < n; ++j) kernel_call(*k, r, j, affine);
      return true;
    }
    switch (op) {
      case Op::Set:
        for (uint32_t i = r.begin; i < r.end; ++i) {
          line("V[" + u(code_[i].out) + "] = V[" + u(code_[i].in[0]) + "];");
        }
        return true;
      case Op::Var:
        for (uint32_t i = r.begin; i < r.end; ++i) {
          const Instr& I = code_[i];
          line("var_home(V[" + u(I.out) + "], S[" + u(I.state) + "], P[" + u(I.param) + "]);");
        }
        return true;
      case Op::Pick:
        for (uint32_t i = r.begin; i < r.end; ++i) {
          const Instr& I = code_[i];
          line("{ const int64_t k = table_pos(P + " + u(I.param) + ", V[" + u(I.in[0]) + "]); V[" + u(I.out) +
               "] = k < 0 ? 0.0 : V[" + table_slot(I) + "]; }");
        }
        return true;
      case Op::Put:
        for (uint32_t i = r.begin; i < r.end; ++i) {
          const Instr& I = code_[i];
          line("{ const int64_t k = table_pos(P + " + u(I.param) + ", V[" + u(I.in[0]) + "]); if (k >= 0) V[" +
               table_slot(I) + "] = V[" + u(I.in[1]) + "]; }");
        }
        return true;
      case Op::Jmp:
        line("goto r" + u(code_[r.begin].out) + ";");
        return true;
      case Op::Jz:
      case Op::Jnz: {
        const Instr& I = code_[r.begin];
        line(std::string("if (V[") + u(I.in[0]) + (op == Op::Jz ? "] == 0.0" : "] != 0.0") + ") goto r" +
             u(I.out) + ";");
        return true;
      }
      case Op::Loop:
        // As the interpreter: one iteration of the budget; past it the cycle ends
        // here, counted as this Loop's error.
        line("if (++iterations > budget) { ++E[" + u(r.begin) + "]; ++bad; if (f->loop_fault != nullptr) "
             "*f->loop_fault = " + u(r.begin + 1) + "; *stop = true; goto done; }");
        line("goto r" + u(code_[r.begin].out) + ";");
        return true;
      default:
        return interpret(ri);
    }
  }

 private:
  static std::string u(uint64_t v) { return std::to_string(v); }
  void line(const std::string& s) {
    body_ += "  ";
    body_ += s;
    body_ += '\n';
  }
  bool interpret(uint32_t ri) {
    line("bad += f->interpret(f->context, " + u(ri) + ");");
    return false;
  }

  // Element j of the run: from the instruction, or from the run's bases when the
  // run is affine (as the interpreter's AffineAccess reads it).
  void kernel_call(const KernelShape& k, const Run& r, uint32_t j, bool affine) {
    uint32_t o, a[3], p, s;
    const uint32_t e = r.begin + j;
    if (affine) {
      const bool uniform = (r.flags & kRunUniformParams) != 0 && k.np > 0;
      o = r.out + j;
      for (int x = 0; x < 3; ++x) a[x] = r.in[x] + j;
      p = r.param + (uniform ? 0 : j * k.np);
      s = r.state + j * k.ns;
    } else {
      const Instr& I = code_[e];
      o = I.out;
      for (int x = 0; x < 3; ++x) a[x] = I.in[x];
      p = I.param;
      s = I.state;
    }
    // Inputs the opcode does not read are never used; keep them in the arena.
    const uint32_t n_in = op_input_count(r.op);
    for (uint32_t x = n_in; x < 3; ++x) a[x] = 0;
    // An input only a constant writes is that constant, so the C++ compiler can
    // fold it (a MOD 2 becomes a test of the low bit) -- when the constant has
    // surely run before this read in the cycle: a read of a later block reads
    // the slot's last value (0 in the first cycle, the old program's after a
    // swap, the retained one after a restart).
    std::string lits;
    unsigned mask = 0;
    for (uint32_t x = 0; x < 3; ++x) {
      const bool lit = x < n_in && constant_[a[x]] && constant_run_[a[x]] < run_ && !skippable_[constant_run_[a[x]]];
      if (lit) mask |= 1u << x;
      lits += ", " + (lit ? literal(constant_value_[a[x]]) : std::string("0.0"));
    }
    line(std::string("bad += k_") + k.name + "(A{V, S, E, " + u(o) + ", " + u(a[0]) + ", " + u(a[1]) + ", " +
         u(a[2]) + ", " + u(p) + ", " + u(s) + ", " + u(e) + ", " + u(mask) + lits + "});");
  }

  // Slots whose one writer in the whole image is a ConstA/ConstD: the value of
  // every read is that constant (the arena still gets it, written by the const).
  void find_constant_slots() {
    const uint32_t n_values = img_.header().n_values;
    const uint32_t n_runs = img_.header().n_runs;
    std::vector<uint32_t> writers(n_values, 0);
    constant_.assign(n_values, false);
    constant_value_.assign(n_values, 0.0);
    constant_run_.assign(n_values, 0);
    // Runs a forward branch may jump over: not surely run in every cycle.
    const std::vector<int32_t> over = passed_over(img_, false);
    skippable_.assign(n_runs, false);
    for (uint32_t ri = 0; ri < n_runs; ++ri) skippable_[ri] = over[ri] > 0;
    std::vector<uint32_t> const_writer(n_values, UINT32_MAX);
    auto wrote = [&](uint64_t slot, uint32_t count, uint32_t instr) {
      for (uint64_t x = slot; x < slot + count && x < n_values; ++x) {
        ++writers[x];
        const_writer[x] = instr;
      }
    };
    for (const Run& r : img_.runs()) {
      const bool affine = (r.flags & kRunAffine) != 0;
      for (uint32_t i = r.begin; i < r.end; ++i) {
        const Instr& I = code_[i];
        const Op op = r.op;
        const uint32_t out = affine ? r.out + (i - r.begin) : I.out;
        if (op_is_store(op) || op_is_branch(op)) continue;
        if (op == Op::Put) {
          const auto n = static_cast<uint32_t>(params_[I.param]);
          for (uint32_t x = 0; x < n; ++x) wrote(static_cast<uint64_t>(params_[I.param + 2 + x]), 1, i);
        } else if (op == Op::Set) {
          wrote(out, 1, i);
        } else if (op == Op::SSet) {
          wrote(out, 1 + static_cast<uint32_t>(params_[I.param]), i);
        } else {
          wrote(out, op_value_width(op, params_.data() + I.param), i);
        }
      }
    }
    for (uint32_t ri = 0; ri < n_runs; ++ri) {
      const Run& r = img_.runs()[ri];
      if (r.op != Op::ConstA && r.op != Op::ConstD) continue;
      const bool affine = (r.flags & kRunAffine) != 0;
      const bool uniform = affine && (r.flags & kRunUniformParams) != 0;
      for (uint32_t i = r.begin; i < r.end; ++i) {
        const uint32_t j = i - r.begin;
        const uint32_t out = affine ? r.out + j : code_[i].out;
        const uint32_t param = affine ? r.param + (uniform ? 0 : j) : code_[i].param;
        if (out >= n_values || writers[out] != 1 || const_writer[out] != i) continue;
        const double v = params_[param];
        constant_[out] = true;
        constant_value_[out] = r.op == Op::ConstD ? (v != 0.0 ? 1.0 : 0.0) : v;
        constant_run_[out] = ri;
      }
    }
  }

  // The slot a Pick/Put's table position k names: base + k when the table is
  // consecutive (a plain array), else a constant table.
  std::string table_slot(const Instr& I) {
    const auto n = static_cast<uint32_t>(params_[I.param]);
    const double* t = params_.data() + I.param + 2;
    bool consecutive = true;
    for (uint32_t x = 1; x < n && consecutive; ++x) consecutive = t[x] == t[0] + x;
    if (consecutive) return u(static_cast<uint32_t>(t[0])) + " + k";
    const std::string name = "table" + u(tables_++);
    globals_ += "static const uint32_t " + name + "[" + u(n) + "] = {";
    for (uint32_t x = 0; x < n; ++x) globals_ += (x ? "," : "") + u(static_cast<uint32_t>(t[x]));
    globals_ += "};\n";
    return name + "[k]";
  }

  const TaskImage& img_;
  std::vector<bool> constant_;
  std::vector<double> constant_value_;
  std::vector<uint32_t> constant_run_;  // the run of the slot's one ConstA
  std::vector<bool> skippable_;         // per run: a forward branch may jump over it
  uint32_t run_ = 0;                    // the run being translated
  std::span<const Instr> code_;
  std::span<const double> params_;
  std::string& globals_;
  std::string& body_;
  uint32_t tables_ = 0;
};

// Removes the private build folder and what is in it, whatever happened.
class WorkDir {
 public:
  explicit WorkDir(std::string path)
      : path_(std::move(path)), fd_(::open(path_.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC)) {}
  ~WorkDir() {
    // Through the folder's own descriptor, opened when it was made: had it been
    // replaced by a link since, nothing outside it is touched. Whatever the
    // compiler left is removed too (a wrapper's files, one level of folders).
    if (fd_ >= 0) {
      if (DIR* d = ::fdopendir(::dup(fd_))) {
        while (const dirent* e = ::readdir(d)) {
          const std::string n = e->d_name;
          if (n == "." || n == "..") continue;
          if (::unlinkat(fd_, n.c_str(), 0) != 0) ::unlinkat(fd_, n.c_str(), AT_REMOVEDIR);
        }
        ::closedir(d);
      }
      ::close(fd_);
    }
    ::rmdir(path_.c_str());
  }
  WorkDir(const WorkDir&) = delete;
  WorkDir& operator=(const WorkDir&) = delete;
  std::string file(const char* name) const { return path_ + "/" + name; }

 private:
  std::string path_;
  int fd_;
};

Result<void> write_new_file(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) return make_error("cannot create " + path + ": " + std::strerror(errno));
  if (const int err = write_fully(fd, text.data(), text.size()); err != 0) {
    ::close(fd);
    return make_error("cannot write " + path + ": " + std::strerror(err));
  }
  if (::close(fd) != 0) return make_error("cannot write " + path + ": " + std::strerror(errno));
  return {};
}

// The compiler's messages, at most `max_lines` of them.
std::string head_of(const std::string& path, int max_lines) {
  std::ifstream in(path);
  std::string out;
  int n = 0;
  for (std::string line; std::getline(in, line) && n < max_lines; ++n) out += "  " + line + "\n";
  return out;
}

}  // namespace

NativeCode::~NativeCode() {
  if (handle_ != nullptr) ::dlclose(handle_);
}

uint64_t image_fingerprint(const TaskImage& image) {
  const auto b = image.bytes();
  return fnv1a64(std::string_view(reinterpret_cast<const char*>(b.data()), b.size()));
}

bool NativeCode::compiled_from(const TaskImage& image) const { return image_fingerprint(image) == fingerprint_; }

namespace {

// Where the code is cut into functions: a C++ compiler's time grows faster than
// the size of one function (a 12,000-block program as one function took minutes),
// so the program becomes parts of about kPartSize instructions, each its own
// function, cut only where no branch crosses (a loop stays whole in its part).
constexpr uint32_t kPartSize = 256;

std::vector<uint32_t> part_starts(const TaskImage& image) {
  const uint32_t n_runs = image.header().n_runs;
  const auto runs = image.runs();
  // A part may start at run b when no branch passes over b: a jump landing on b
  // lands on the previous part's end label, and a loop back to b stays whole.
  const std::vector<int32_t> crossing = passed_over(image, true);
  std::vector<uint32_t> starts = {0};
  uint32_t size = 0;
  for (uint32_t b = 0; b < n_runs; ++b) {
    if (b > 0 && crossing[b] == 0 && size >= kPartSize) {
      starts.push_back(b);
      size = 0;
    }
    size += runs[b].end - runs[b].begin;
  }
  return starts;
}

}  // namespace

std::string native_source(const TaskImage& image, NativeStats* stats) {
  const uint32_t n_runs = image.header().n_runs;
  const auto runs = image.runs();
  const auto code = image.code();
  // Labels only where a branch lands (and each part's end), so the compiler sees
  // long straight stretches.
  std::vector<bool> target(n_runs + 1, false);
  for (const Run& r : runs) {
    if (op_is_branch(r.op)) target[code[r.begin].out] = true;
  }
  std::string globals, parts, body;
  NativeStats st;
  Translator tr(image, globals, body);
  const std::vector<uint32_t> starts = part_starts(image);
  for (size_t k = 0; k < starts.size(); ++k) {
    const uint32_t begin = starts[k], end = k + 1 < starts.size() ? starts[k + 1] : n_runs;
    body.clear();
    for (uint32_t ri = begin; ri < end; ++ri) {
      if (target[ri]) body += "r" + std::to_string(ri) + ":;\n";
      if (tr.run(ri, runs[ri])) {
        ++st.native_runs;
      } else {
        ++st.interpreted_runs;
      }
    }
    // The budget in a local: a load through `f` might alias the error counters,
    // which would keep the compiler from holding them in registers in a loop.
    parts += "__attribute__((noinline)) uint64_t part" + std::to_string(k) +
             "(const RtplcNativeFrame* f, uint64_t* iterations_io, bool* stop) {\n"
             "  double* const V = f->values;\n  double* const S = f->state;\n  uint64_t* const E = f->errors;\n"
             "  const uint64_t budget = f->loop_budget;\n  uint64_t bad = 0, iterations = *iterations_io;\n"
             "  (void)V; (void)S; (void)E; (void)budget; (void)stop;\n";
    parts += body;
    parts += "r" + std::to_string(end) + ":;\ndone:\n  *iterations_io = iterations;\n  return bad;\n}\n\n";
  }
  const uint64_t fp = image_fingerprint(image);
  std::string src;
  // Nothing of the image's text goes into the source but this name, cut to
  // characters that cannot end the comment: an image file or a file name with a
  // newline in it must not become code.
  std::string name;
  for (const char c : image.name().substr(0, 64)) {
    name += std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-' ? c : '_';
  }
  src += "// Native code rtplc generated for the task image " + name + " (" + hex64(fp) +
         "): compiled, loaded and removed by rtplc.\n";
  src += "#include <bit>\n#include <cmath>\n#include <cstdint>\n";
  src += kit_text(native_kit::kAbi);
  src += kit_text(native_kit::kIntMath);
  src += "namespace rtplc_native {\nnamespace int_math = ::rtplc::int_math;\nnamespace {\n";
  src += kit_text(native_kit::kKernels);
  // The prepared parameters as constants: the image never changes them, and the
  // compiler folds what it knows (a wrap's range, a scale's factor).
  src += "const double P[] = {";
  const auto params = image.params();
  for (size_t i = 0; i < params.size(); ++i) src += (i % 8 == 0 ? "\n  " : " ") + literal(params[i]) + ",";
  src += "\n  0.0};\n";
  src += R"(
// One instruction's operands: constants once the kernel is inlined. Input k is
// the literal c_k when bit k of lit_ is set (a slot only a constant writes).
struct A {
  double* V;
  double* S;
  uint64_t* E;
  uint32_t o_, a0_, a1_, a2_, p_, s_, e_, lit_;
  double c0_, c1_, c2_;
  RTPLC_INLINE double in(int k) const {
    if (k == 0) return (lit_ & 1u) ? c0_ : V[a0_];
    if (k == 1) return (lit_ & 2u) ? c1_ : V[a1_];
    return (lit_ & 4u) ? c2_ : V[a2_];
  }
  RTPLC_INLINE double p(int k) const { return P[p_ + static_cast<uint32_t>(k)]; }
  RTPLC_INLINE double& s(int k) const { return S[s_ + static_cast<uint32_t>(k)]; }
  RTPLC_INLINE double& y() const { return V[o_]; }
  RTPLC_INLINE uint64_t& err() const { return E[e_]; }
};
)";
  src += globals;
  src += parts;
  src += "}  // namespace\n}  // namespace rtplc_native\nusing namespace rtplc_native;\n\n";
  src += "extern \"C\" __attribute__((visibility(\"default\"))) const char rtplc_native_tag[] = \"" + native_tag(fp) +
         "\";\n\n";
  src += "extern \"C\" __attribute__((visibility(\"default\"))) uint64_t rtplc_native_cycle(const RtplcNativeFrame* f) "
         "{\n  uint64_t bad = 0, iterations = 0;\n  bool stop = false;\n";
  for (size_t k = 0; k < starts.size(); ++k) {
    src += "  bad += part" + std::to_string(k) + "(f, &iterations, &stop);\n";
    if (k + 1 < starts.size()) src += "  if (stop) return bad;\n";
  }
  src += "  return bad;\n}\n";
  st.source_bytes = src.size();
  if (stats != nullptr) *stats = st;
  return src;
}

Result<std::shared_ptr<const NativeCode>> compile_native(const TaskImage& image, const NativeOptions& options) {
  NativeStats stats;
  const std::string source = native_source(image, &stats);

  std::string base = options.work_dir;
  if (base.empty()) {
    const char* t = std::getenv("TMPDIR");
    base = t != nullptr && *t != '\0' ? t : "/tmp";
  }
  // mkdtemp makes a new folder only we may enter. Someone else who may rename
  // entries of the base folder could still put another folder in ours' place
  // between writing the source and loading the library: the base must be
  // root's or ours, and writable by others only when sticky.
  struct stat bs {};
  if (::stat(base.c_str(), &bs) == 0) {
    const bool owner_ok = bs.st_uid == 0 || bs.st_uid == ::geteuid();
    const bool others_write = (bs.st_mode & (S_IWGRP | S_IWOTH)) != 0;
    if (!owner_ok || (others_write && (bs.st_mode & S_ISVTX) == 0)) {
      return make_error("native code: " + base + " is not a safe place to build in (another user's, or writable by "
                        "others and not sticky); set TMPDIR to a folder of root's or the runtime's own");
    }
  }
  std::string templ = base + "/rtplc-native-XXXXXX";
  if (::mkdtemp(templ.data()) == nullptr) {
    return make_error("native code: cannot make a build folder in " + base + ": " + std::strerror(errno));
  }
  const WorkDir dir(templ);
  if (auto w = write_new_file(dir.file("task.cpp"), source); !w) return make_error("native code: " + w.error());

  std::string compiler = options.compiler;
  if (compiler.empty()) {
    const char* c = std::getenv("RTPLC_CXX");
    compiler = c != nullptr && *c != '\0' ? c : "c++";
  }
  const std::string src_path = dir.file("task.cpp"), so_path = dir.file("task.so"), log_path = dir.file("compiler.log");
  // The interpreter's floating-point options (blocks/CMakeLists.txt): no
  // contraction, so both give the same bits.
  std::vector<std::string> args = {compiler,        "-std=c++20",     "-O2",       "-fPIC",
                                   "-shared",       "-fno-trapping-math", "-ffp-contract=off", "-fno-exceptions",
                                   "-fno-rtti",     "-fvisibility=hidden", "-w",         "-o",
                                   so_path,         src_path};
  // The C++ compiler may compute these at compile time, correctly rounded, or
  // rewrite pow(x, 2) as x*x; the interpreter calls the C library, which is not
  // always correctly rounded. The same call at run time gives the same bits.
  for (const char* f : {"sin", "cos", "tan", "asin", "acos", "atan", "log", "log10", "exp", "pow"}) {
    args.insert(args.begin() + 1, std::string("-fno-builtin-") + f);
  }
#if defined(__x86_64__)
  // SSE4.1 rounds in one instruction (trunc, nearbyint: every integer step and
  // array index) where plain x86-64 calls libm: 40% of the loop benchmark's
  // time. The same IEEE results; the library is built for this very machine.
  __builtin_cpu_init();
  if (__builtin_cpu_supports("sse4.1")) args.insert(args.begin() + 1, "-msse4.1");
#endif
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW, 0600);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  // The compiler starts with no signal blocked and every signal at its default
  // (the runtime's control thread blocks SIGTERM and ignores SIGPIPE), at the
  // normal scheduling policy whatever thread asks, in a process group of its
  // own so a timeout stops the driver and the compiler it runs.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigfillset(&defaults);
  sigdelset(&defaults, SIGKILL);
  sigdelset(&defaults, SIGSTOP);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  sched_param normal{};
  posix_spawnattr_setschedpolicy(&attr, SCHED_OTHER);
  posix_spawnattr_setschedparam(&attr, &normal);
  posix_spawnattr_setpgroup(&attr, 0);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSCHEDULER |
                                      POSIX_SPAWN_SETPGROUP);
  const auto t0 = std::chrono::steady_clock::now();
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, compiler.c_str(), &fa, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&attr);
  if (rc == ENOENT || rc == EACCES || rc == ENOEXEC) {
    return make_error("native code needs a C++ compiler: cannot run `" + compiler + "` (" + std::strerror(rc) +
                      "); install g++, or name one in RTPLC_CXX");
  }
  if (rc != 0) return make_error("native code: cannot start `" + compiler + "`: " + std::strerror(rc));
  int status = 0;
  bool timed_out = false, aborted = false;
  uint32_t polls = 0;
  // Stops the compiler's whole group and reaps the driver.
  auto stop_compiler = [&] {
    ::kill(-pid, SIGKILL);
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
  };
  for (;;) {
    const pid_t w = ::waitpid(pid, &status, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) {
      const int err = errno;
      stop_compiler();
      return make_error(std::string("native code: waiting for the compiler: ") + std::strerror(err));
    }
    if (std::chrono::steady_clock::now() - t0 > std::chrono::duration<double>(options.timeout_s)) {
      timed_out = true;
      stop_compiler();
      break;
    }
    ::usleep(20'000);
    if (options.while_waiting && ++polls % 5 == 0) {
      bool go_on = false;
      try {
        go_on = options.while_waiting();
      } catch (...) {
        go_on = false;
      }
      if (!go_on) {
        aborted = true;
        stop_compiler();
        break;
      }
    }
  }
  stats.compile_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (aborted) return make_error("native code: the compile was stopped (the runtime is stopping)");
  if (timed_out) {
    return make_error("native code: `" + compiler + "` took more than " + std::to_string(options.timeout_s) +
                      " s and was stopped; run this task on the interpreter (native: false)");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    const std::string why = WIFEXITED(status) ? "exited with " + std::to_string(WEXITSTATUS(status))
                                              : "was killed by signal " + std::to_string(WTERMSIG(status));
    return make_error("native code: `" + compiler + "` " + why + " on the generated source:\n" +
                      head_of(log_path, 20) + "(`rtplc compile FILE --native-source F.cpp` writes that source)");
  }
  // The library: ours, a plain file, not a link (in a folder only we may enter).
  const int so_fd = ::open(so_path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  struct stat so {};
  if (so_fd < 0 || ::fstat(so_fd, &so) != 0 || !S_ISREG(so.st_mode) || so.st_uid != ::geteuid()) {
    if (so_fd >= 0) ::close(so_fd);
    return make_error("native code: the compiled library is missing or not the compiler's own file");
  }
  // By its path, which is new for every compile: the loader takes a path it
  // has loaded before for that library (a /proc/self/fd/N path comes back).
  void* handle = ::dlopen(so_path.c_str(), RTLD_NOW | RTLD_LOCAL);
  ::close(so_fd);
  if (handle == nullptr) {
    const char* e = ::dlerror();
    return make_error(std::string("native code: the compiled library does not load (is ") + base +
                      " mounted noexec? set TMPDIR): " + (e ? e : "?"));
  }
  const uint64_t fp = image_fingerprint(image);
  const auto* tag = static_cast<const char*>(::dlsym(handle, "rtplc_native_tag"));
  auto entry = reinterpret_cast<RtplcNativeCycle>(::dlsym(handle, "rtplc_native_cycle"));
  if (tag == nullptr || entry == nullptr || native_tag(fp) != tag) {
    ::dlclose(handle);
    return make_error("native code: the compiled library is not the one generated for this image");
  }
  return std::shared_ptr<const NativeCode>(std::make_shared<NativeCode>(handle, entry, fp, stats));
}

}  // namespace rtplc
