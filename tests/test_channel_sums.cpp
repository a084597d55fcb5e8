// The per-channel byte sums of interleaved 3-channel rows (classify/channel_sums.hpp): every
// kernel this CPU runs against a plain loop, exactly, on random rows of every width up to 100
// (all the vector tails), rows of 255 long enough to overflow a 16-bit or a vpsadbw lane if one
// were kept too long, and misaligned starts. Without OpenCV, so the aarch64 build under
// emulation runs it too (.ci/steps/50_aarch64.sh).
#include <shadowsense/classify/channel_sums.hpp>

#include <doctest/doctest.h>

#include <cstdint>
#include <random>
#include <vector>

using namespace shadowsense;

namespace {

ChannelSums plain_sums(const unsigned char* row, int pixels) {
  ChannelSums s{0, 0, 0};
  for (int i = 0; i < 3 * pixels; ++i) s[static_cast<std::size_t>(i % 3)] += row[i];
  return s;
}

std::vector<ChannelSumsKind> kernels_here() {
  std::vector<ChannelSumsKind> k;
  for (auto kind : {ChannelSumsKind::portable, ChannelSumsKind::avx2, ChannelSumsKind::avx512,
                    ChannelSumsKind::neon})
    if (channel_sums_cpu_has(kind)) k.push_back(kind);
  return k;
}

} // namespace

TEST_CASE("add_channel_sums: every kernel gives the plain loop's sums, exactly") {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> byte(0, 255);
  const auto kinds = kernels_here();
  REQUIRE(kinds.size() >= 1);
  for (const auto kind : kinds) {
    CAPTURE(static_cast<int>(kind));
    for (int w = 0; w <= 100; ++w)
      for (int offset = 0; offset < 3; ++offset) { // starts off any vector alignment
        std::vector<unsigned char> buf(static_cast<std::size_t>(3 * w + offset));
        for (auto& b : buf) b = static_cast<unsigned char>(byte(rng));
        const unsigned char* row = buf.data() + offset;
        ChannelSums got{1, 2, 3}; // the kernels add to what is there
        add_channel_sums(row, w, got, kind);
        const ChannelSums want = plain_sums(row, w);
        CAPTURE(w);
        CHECK(got[0] == want[0] + 1);
        CHECK(got[1] == want[1] + 2);
        CHECK(got[2] == want[2] + 3);
      }
    // 40000 random pixels: several of the AVX-512 kernel's 256-step flushes, each lane added
    // to its channel.
    std::vector<unsigned char> long_row(3 * 40000);
    for (auto& b : long_row) b = static_cast<unsigned char>(byte(rng));
    ChannelSums long_got{0, 0, 0};
    add_channel_sums(long_row.data(), 40000, long_got, kind);
    CHECK(long_got == plain_sums(long_row.data(), 40000));
    // 70000 pixels of 255 and one channel of 0: a 16-bit lane kept past 257 steps or a
    // 32-bit lane of the wrong width would wrap.
    std::vector<unsigned char> big(3 * 70000, 255);
    for (std::size_t i = 1; i < big.size(); i += 3) big[i] = 0;
    ChannelSums got{0, 0, 0};
    add_channel_sums(big.data(), 70000, got, kind);
    CHECK(got[0] == 255ull * 70000);
    CHECK(got[1] == 0);
    CHECK(got[2] == 255ull * 70000);
  }
  // automatic is one of them
  std::vector<unsigned char> row(3 * 37);
  for (auto& b : row) b = static_cast<unsigned char>(byte(rng));
  ChannelSums got{0, 0, 0};
  add_channel_sums(row.data(), 37, got);
  CHECK(got == plain_sums(row.data(), 37));
}

TEST_CASE("add_channel_sums: a kernel this build or CPU lacks is refused by name") {
  bool refused_one = false;
  for (auto kind : {ChannelSumsKind::avx2, ChannelSumsKind::avx512, ChannelSumsKind::neon})
    if (!channel_sums_cpu_has(kind)) {
      ChannelSums s{0, 0, 0};
      const unsigned char row[3] = {1, 2, 3};
      CHECK_THROWS_WITH_AS(add_channel_sums(row, 1, s, kind),
                           doctest::Contains("not compiled in or this CPU cannot run it"),
                           InvalidArgument);
      refused_one = true;
    }
  CHECK(refused_one); // no build has both AVX2 and NEON
}
