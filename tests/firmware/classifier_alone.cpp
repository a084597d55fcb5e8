// classify/classifier.hpp alone must not declare the DenseNet backend (a user backend does not
// drag in the GEMM and thread pool): if it did, DenseNet, ModelFile and ThreadPool below would
// be ambiguous and this file would not compile. Compiled on its own by
// check_include_closure.cmake (a test file cannot hold it: the tests share a precompiled header
// that declares everything).
#include <shadowsense/classify/classifier.hpp>

namespace include_probe_names {
struct DenseNet;
struct ModelFile;
struct ThreadPool;
} // namespace include_probe_names
namespace include_probe {
using namespace shadowsense;
using namespace shadowsense::detail;
using namespace include_probe_names;
static_assert(sizeof(DenseNet*) + sizeof(ModelFile*) + sizeof(ThreadPool*) > 0);
} // namespace include_probe

int main() {}
