// A firmware-style consumer: includes only the runtime umbrella header. The include_closure
// test compiles it with the runtime's include paths alone (no Eigen, no imgcodecs) and fails if
// any header of the generator, training, I/O or evaluation targets is pulled in.
#include <shadowsense/shadowsense.hpp>

int main() {
  namespace ss = shadowsense;
  ss::Segmenter segmenter;
  ss::TouchStateMachine fsm;
  (void)segmenter;
  (void)fsm;
  return ss::version_major == SHADOWSENSE_VERSION_MAJOR ? 0 : 1;
}
