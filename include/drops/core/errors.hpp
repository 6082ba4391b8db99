#pragma once
/// \file Project exceptions. Every public entry point reports bad input by throwing one of these.

#include <stdexcept>
#include <string>

namespace drops {

/// Base class of every exception thrown by drops.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A caller passed an argument of the wrong size or value ("expected X, got Y").
class InvalidArgument : public Error {
 public:
  using Error::Error;
};

/// A numerical procedure failed (e.g. Cholesky after the bounded jitter retries, NaN from a simulator).
class NumericalError : public Error {
 public:
  using Error::Error;
};

/// A user configuration (YAML file, key=value override, CLI) is invalid; the message names the key,
/// the value and what is allowed.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// Throws InvalidArgument("<what>: expected <expected>, got <got>") when expected != got.
/// Thread-safe.
inline void check_size(const char* what, long expected, long got) {
  if (expected != got) {
    throw InvalidArgument(std::string(what) + ": expected size " + std::to_string(expected) +
                          ", got " + std::to_string(got));
  }
}

}  // namespace drops
