// The library's exceptions. Every public entry point validates its input and throws one of
// these with a message that names what was wrong and what was expected.
#pragma once

#include <shadowsense/core/version.hpp>

#include <stdexcept>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

// Base of every exception the library throws.
class Error : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// A function argument or configuration value is outside what the function accepts.
class InvalidArgument : public Error {
public:
  using Error::Error;
};

// A model file is malformed, truncated, of another version or inconsistent with itself.
class ModelFileError : public Error {
public:
  using Error::Error;
};

// A dataset folder or metadata file is missing, malformed or inconsistent.
class DatasetError : public Error {
public:
  using Error::Error;
};

// Reading or writing a file failed.
class IoError : public Error {
public:
  using Error::Error;
};

namespace detail {
// Throws E(message) unless condition holds. Keeps validation one line per rule.
template <class E = InvalidArgument>
inline void require(bool condition, const std::string& message) {
  if (!condition) throw E(message);
}
} // namespace detail

SHADOWSENSE_NAMESPACE_END
