// Task images are verified before they run: a corrupted or hostile image is
// rejected with a reason, never executed.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "blocks/executor.h"
#include "blocks/image.h"
#include "lang/compiler.h"

namespace rtplc {
namespace {

const char* kProgram =
    "MACRO PID(2|0|3)\n%%\nstime(0.1)\nF1 = dai(p0, d0, c0, \"ProcVal\")\n"
    "F2 = asp(d0, c0, 50, \"Setpoint\")\nF10 = MACRO PID(F2, F1, 4, 3, 1)\n"
    "F11 = dely(F10, 4)\nF12 = lim(F11, -5, 5)\ndao(F10, p0, d0, c0, \"ManiVal\")\nEND\n%%\n"
    "MACRO PID(M1, M2, P1, P2, P3)\n{\nM3 = sub(M1, M2, 1)\nM4 = epi(M3, P1, P2)\n"
    "M5 = deriv(M2, P3)\nM7 = sub(M4, M5, 1)\nRETURN(M7)\n}\n";

TaskImage compiled() {
  auto r = lang::compile_source(kProgram);
  EXPECT_TRUE(r.ok()) << r.diags.render("t", kProgram);
  return std::move(*r.image);
}

std::vector<std::byte> copy_of(const TaskImage& img) {
  return {img.bytes().begin(), img.bytes().end()};
}

Result<void> verify(std::vector<std::byte>& b) {
  // Verify wants 8-byte alignment; copy into aligned storage.
  std::vector<uint64_t> words((b.size() + 7) / 8);
  std::memcpy(words.data(), b.data(), b.size());
  return verify_image({reinterpret_cast<const std::byte*>(words.data()), b.size()});
}

template <typename T>
T& at(std::vector<std::byte>& b, uint64_t off) {
  return *reinterpret_cast<T*>(b.data() + off);
}

TEST(Image, a_compiled_image_verifies_and_round_trips_through_bytes) {
  TaskImage img = compiled();
  auto bytes = copy_of(img);
  ASSERT_TRUE(verify(bytes).ok()) << verify(bytes).error();
  auto back = TaskImage::from_bytes(img.bytes());
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->header().n_instr, img.header().n_instr);
  EXPECT_EQ(std::memcmp(back->bytes().data(), img.bytes().data(), img.bytes().size()), 0);
  EXPECT_STREQ(back->name().data(), "program");
}

TEST(Image, compiling_twice_gives_identical_bytes) {
  TaskImage a = compiled(), b = compiled();
  ASSERT_EQ(a.bytes().size(), b.bytes().size());
  EXPECT_EQ(std::memcmp(a.bytes().data(), b.bytes().data(), a.bytes().size()), 0);
}

TEST(Image, rejects_each_kind_of_corruption) {
  TaskImage img = compiled();
  const ImageHeader& h = img.header();
  struct Case {
    const char* name;
    void (*mutate)(std::vector<std::byte>&, const ImageHeader&);
  };
  const Case cases[] = {
      {"magic", [](auto& b, auto&) { b[0] = std::byte{'X'}; }},
      {"version", [](auto& b, auto&) { at<uint32_t>(b, offsetof(ImageHeader, version)) = 99; }},
      {"size", [](auto& b, auto&) { at<uint64_t>(b, offsetof(ImageHeader, total_size)) += 8; }},
      {"period", [](auto& b, auto&) { at<double>(b, offsetof(ImageHeader, dt)) = -1; }},
      {"section offset", [](auto& b, auto&) { at<uint64_t>(b, offsetof(ImageHeader, off_instr)) = 1u << 30; }},
      {"instruction count", [](auto& b, auto&) { at<uint32_t>(b, offsetof(ImageHeader, n_instr)) = 1u << 30; }},
      {"opcode", [](auto& b, auto& hh) { at<Instr>(b, hh.off_instr).op = static_cast<Op>(250); }},
      {"input slot", [](auto& b, auto& hh) { at<Instr>(b, hh.off_instr + 2 * sizeof(Instr)).in[0] = 1u << 20; }},
      {"output slot", [](auto& b, auto& hh) { at<Instr>(b, hh.off_instr + 2 * sizeof(Instr)).out = 999999; }},
      {"second writer", [](auto& b, auto& hh) {
         at<Instr>(b, hh.off_instr + 3 * sizeof(Instr)).out = at<Instr>(b, hh.off_instr + 2 * sizeof(Instr)).out;
       }},
      {"params", [](auto& b, auto& hh) { at<Instr>(b, hh.off_instr + 2 * sizeof(Instr)).param = 1u << 28; }},
      {"state", [](auto& b, auto& hh) {
         for (uint32_t i = 0; i < hh.n_instr; ++i) {
           Instr& in = at<Instr>(b, hh.off_instr + i * sizeof(Instr));
           if (op_state_size(in.op, nullptr) > 0 && in.op != Op::Dely) in.state = hh.n_state;
         }
       }},
      {"nan parameter", [](auto& b, auto& hh) { at<double>(b, hh.off_params) = NAN; }},
      {"run coverage", [](auto& b, auto& hh) { at<rtplc::Run>(b, hh.off_runs).end += 1; }},
      {"binding", [](auto& b, auto& hh) { at<Binding>(b, hh.off_bindings).io_index = 77; }},
      {"label string", [](auto& b, auto& hh) { at<Binding>(b, hh.off_bindings).label = 1u << 30; }},
      {"string pool end", [](auto& b, auto& hh) { b[hh.off_strings + hh.n_strings - 1] = std::byte{'x'}; }},
  };
  for (const Case& c : cases) {
    auto bytes = copy_of(img);
    c.mutate(bytes, h);
    EXPECT_FALSE(verify(bytes).ok()) << c.name;
    EXPECT_FALSE(TaskImage::from_bytes(bytes).ok()) << c.name;
  }
}

TEST(Image, the_body_check_value_matches_a_compiled_image_and_catches_any_changed_byte) {
  TaskImage img = compiled();
  EXPECT_EQ(img.header().body_check, image_body_check(img.bytes()));
  EXPECT_NE(img.header().body_check, 0u);
  auto bytes = copy_of(img);
  for (size_t at : {sizeof(ImageHeader), bytes.size() / 2, bytes.size() - 1}) {
    auto b = bytes;
    b[at] ^= std::byte{0x01};
    EXPECT_NE(image_body_check(b), img.header().body_check) << "byte " << at;
  }
}

TEST(Image, rejects_a_dely_whose_sample_count_exceeds_its_state) {
  TaskImage img = compiled();
  auto bytes = copy_of(img);
  const ImageHeader& h = img.header();
  for (uint32_t i = 0; i < h.n_instr; ++i) {
    const Instr& in = at<Instr>(bytes, h.off_instr + i * sizeof(Instr));
    if (in.op == Op::Dely) at<double>(bytes, h.off_params + in.param * 8) = 1e6;
  }
  EXPECT_FALSE(verify(bytes).ok());
}

TEST(Image, random_byte_flips_never_pass_as_a_different_valid_image_that_crashes) {
  // Flip random bytes; whatever verifies must also run without touching memory
  // out of bounds (ASan builds catch it if not).
  TaskImage img = compiled();
  std::mt19937 rng(7);
  for (int trial = 0; trial < 2000; ++trial) {
    auto bytes = copy_of(img);
    for (int k = 0; k < 3; ++k) {
      bytes[rng() % bytes.size()] = static_cast<std::byte>(rng());
    }
    auto v = TaskImage::from_bytes(bytes);
    if (!v) continue;
    TaskArena arena(*v);
    for (int c = 0; c < 3; ++c) execute_cycle(*v, arena);
  }
}

}  // namespace
}  // namespace rtplc
