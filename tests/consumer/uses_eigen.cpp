// Must NOT build where Eigen is hidden from the consumer (tests/install/consumers.cmake): it
// proves that shadowsense::shadowsense (and the pkg-config flags) put no Eigen include path on
// the consumer's command line. Eigen first, so the compiler stops at once.
#include <Eigen/Core>
#include <shadowsense/shadowsense.hpp>

int main() {
  Eigen::Vector2f v(1.0f, 2.0f);
  return v.sum() == 3.0f && shadowsense::version_major == 0 ? 0 : 1;
}
