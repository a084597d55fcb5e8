// The exception policy: a program that defines SHADOWSENSE_THROW before including the library
// receives every library error through its own handler (here: recorded, then rethrown as a
// type the library does not know, so a test can see the handler ran instead of `throw`).
#include <string>
#include <typeinfo>

namespace policy {
struct Handled {
  std::string type;
  std::string message;
};
inline int calls = 0;
template <class E>
[[noreturn]] void raise(const E& e) {
  ++calls;
  throw Handled{typeid(E).name(), e.what()};
}
} // namespace policy

#define SHADOWSENSE_THROW(exception) ::policy::raise(exception)

#include <shadowsense/eval.hpp>

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

using namespace shadowsense;

namespace {
// Runs f, expects the handler to be called exactly once with an E, returns its message.
template <class E, class F>
std::string handled_message(F f) {
  const int before = policy::calls;
  try {
    f();
  } catch (const policy::Handled& h) {
    CHECK(policy::calls == before + 1);
    CHECK(h.type == std::string(typeid(E).name()));
    return h.message;
  } catch (const std::exception& e) {
    FAIL("the library threw directly instead of through SHADOWSENSE_THROW: " << e.what());
  }
  FAIL("no error was raised");
  return {};
}
} // namespace

TEST_CASE("detail::require raises through the user's SHADOWSENSE_THROW") {
  CHECK(handled_message<InvalidArgument>([] { detail::require(false, "rule broken"); }) ==
        "rule broken");
  CHECK(handled_message<IoError>([] { detail::require<IoError>(false, "disk"); }) == "disk");
  const int before = policy::calls;
  detail::require(true, "never raised");
  CHECK(policy::calls == before);
}

TEST_CASE("direct error sites in core and io raise through the user's SHADOWSENSE_THROW") {
  CHECK(handled_message<InvalidArgument>([] { (void)direction_from_string("up"); }) ==
        "direction 'up' is unknown; expected left, right, front, back or none");
  CHECK(handled_message<InvalidArgument>([] { require_colour_image(cv::Mat(), "frame"); }) ==
        "frame: image is empty; expected an 8-bit 3-channel image");
  const std::string m = handled_message<DatasetError>(
      [] { (void)read_metadata("/nonexistent/shadowsense/metadata.csv"); });
  CHECK(m.find("/nonexistent/shadowsense/metadata.csv") != std::string::npos);
}

TEST_CASE("the dataset reader's row errors also arrive through the user's handler, located") {
  const std::string m = handled_message<DatasetError>([] {
    (void)parse_metadata("file_name,class,user,lighting,lighting_level,session,frame_index,"
                         "timestamp_ms,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,"
                         "contact_w,contact_h,contact_cx,contact_cy,px_per_cm\n"
                         "a.png,palm,1,noon,0.5,s,0,0,,,,,,,,,,,1\n",
                         "d/metadata.csv");
  });
  CHECK(m == "d/metadata.csv:2: column 4 'lighting': unknown lighting 'noon'; expected daylight, "
             "dusk, night or custom; got 'noon'");
}
