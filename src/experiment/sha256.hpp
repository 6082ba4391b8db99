#pragma once
// SHA-256 (FIPS 180-4, computed by OpenSSL's libcrypto), for the checksums that checkpoint.json keeps of the files of a run
// directory (run_directory.cpp). Internal to drops::experiment.

#include <cstdint>
#include <string>
#include <string_view>

namespace drops::experiment {

/// The SHA-256 digest of `data` as 64 lowercase hexadecimal digits (FIPS 180-4, section 6.2).
/// Thread-safe.
std::string sha256_hex(std::string_view data);

}  // namespace drops::experiment
