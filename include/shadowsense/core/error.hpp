// The library's exceptions and its exception policy.
//
// WHAT THIS IS
//   Every public entry point validates its input and reports a failure by throwing one of the
//   types below with a message that names what was wrong and what was expected.
//
//   Every throw in the library goes through one macro, SHADOWSENSE_THROW(exception), the way
//   nlohmann/json routes its throws through JSON_THROW_USER. By default it is `throw exception`.
//   A firmware build without exceptions (-fno-exceptions) defines it BEFORE including any
//   shadowsense header (or on the command line) to call its own handler, for example:
//
//     [[noreturn]] void on_shadowsense_error(const shadowsense::Error& e); // logs, aborts
//     #define SHADOWSENSE_THROW(exception) on_shadowsense_error(exception)
//     #include <shadowsense/shadowsense.hpp>
//
//   requires of a user definition:
//     - it must not return to the library (the handler is [[noreturn]]: it aborts, resets,
//       longjmps out, or throws something else); code after a throw assumes it never runs.
//     - it is given an expression of one of the types below (always derived from Error);
//       the argument is evaluated exactly once.
//     - the same definition in every translation unit of a program (ODR).
//   The runtime umbrella (<shadowsense/shadowsense.hpp>) has no try, catch or rethrow of its
//   own: the few places that add context to an inner error (a model file's name, "Preprocessor
//   config: ") go through detail::add_context, which without exceptions just runs the inner
//   code, so the handler then receives the inner message without that prefix. CI compiles and
//   runs a firmware program with -fno-exceptions (tests/firmware/no_exceptions.cpp).
//
// THREADING
//   Stateless; the exception types are ordinary value types.
#pragma once

#include <shadowsense/core/version.hpp>

#include <stdexcept>
#include <string>

#ifndef SHADOWSENSE_THROW
#define SHADOWSENSE_THROW(exception) throw exception
#endif

#if defined(__cpp_exceptions) || defined(__EXCEPTIONS)
#define SHADOWSENSE_HAS_EXCEPTIONS 1
#else
#define SHADOWSENSE_HAS_EXCEPTIONS 0
#endif

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

// A model file is malformed, truncated, of another version or inconsistent with itself. Also
// the base of CalibrationFileError, so a catch of ModelFileError written for both files (they
// were one type before) still catches a bad calibration file.
class ModelFileError : public Error {
public:
  using Error::Error;
};

// A segmenter calibration file (sense/calibration_file.hpp) is malformed, truncated, of another
// version or inconsistent with itself.
class CalibrationFileError : public ModelFileError {
public:
  using ModelFileError::ModelFileError;
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

// One instance of a type that is not internally synchronised was used from two threads at
// once (core/thread_owner.hpp). A programming error in the caller: use one instance per thread.
class ConcurrentUseError : public Error {
public:
  using Error::Error;
};

namespace detail {
// require<E>(condition, message)
//   ensures: returns normally when condition holds; otherwise raises E(message) through
//            SHADOWSENSE_THROW. Keeps validation one line per rule. A string-literal message
//            allocates nothing when the condition holds (build a concatenated message only
//            inside `if (!condition)` on per-frame paths).
template <class E = InvalidArgument>
inline void require(bool condition, const std::string& message) {
  if (!condition) SHADOWSENSE_THROW(E(message));
}
// A literal message is only turned into a std::string when the check fails, so passing checks
// on a per-frame path allocate nothing.
template <class E = InvalidArgument>
inline void require(bool condition, const char* message) {
  if (!condition) SHADOWSENSE_THROW(E(std::string(message)));
}

// add_context<Caught, Thrown = Caught>(prefix, body) -> body()
//   ensures: returns what body() returns; a Caught that body throws is raised again as
//            Thrown(prefix + what()) through SHADOWSENSE_THROW. Without exceptions body() is
//            simply run (its own SHADOWSENSE_THROW reports, without the prefix).
template <class Caught, class Thrown = Caught, class Body>
inline decltype(auto) add_context([[maybe_unused]] const std::string& prefix, Body&& body) {
#if SHADOWSENSE_HAS_EXCEPTIONS
  try {
    return body();
  } catch (const Caught& e) {
    SHADOWSENSE_THROW(Thrown(prefix + e.what()));
  }
#else
  return body();
#endif
}
} // namespace detail

SHADOWSENSE_NAMESPACE_END
