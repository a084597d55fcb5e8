// Version and the inline ABI namespace: two vendored copies of different versions can live in
// one program without violating the one-definition rule.
#pragma once

#define SHADOWSENSE_VERSION_MAJOR 0
#define SHADOWSENSE_VERSION_MINOR 1
#define SHADOWSENSE_VERSION_PATCH 0

// Bump together with the version numbers above.
#define SHADOWSENSE_ABI_NAMESPACE v0_1

#define SHADOWSENSE_NAMESPACE_BEGIN                                                                \
  namespace shadowsense {                                                                          \
  inline namespace SHADOWSENSE_ABI_NAMESPACE {
#define SHADOWSENSE_NAMESPACE_END                                                                  \
  }                                                                                                \
  }

SHADOWSENSE_NAMESPACE_BEGIN
inline constexpr int version_major = SHADOWSENSE_VERSION_MAJOR;
inline constexpr int version_minor = SHADOWSENSE_VERSION_MINOR;
inline constexpr int version_patch = SHADOWSENSE_VERSION_PATCH;
inline constexpr const char* version_string = "0.1.0";
SHADOWSENSE_NAMESPACE_END
