// SPDX-License-Identifier: GPL-3.0-or-later
// The text encodings shop-floor software writes DMIS files in, detected and read as UTF-8.
#pragma once
#include <string>
#include <string_view>

namespace metron {

/// What a file's bytes were found to be.
enum class TextEncoding {
  Ascii,        ///< 7-bit only: the same in every encoding
  Utf8,         ///< valid UTF-8 with at least one multi-byte character
  Windows1252,  ///< not valid UTF-8: read as Windows-1252 (a superset of Latin-1's printable characters)
  Utf16Le,      ///< UTF-16, little-endian (Windows "Unicode"): a BOM FF FE, or NUL after each ASCII byte
  Utf16Be,      ///< UTF-16, big-endian: a BOM FE FF, or NUL before each ASCII byte
};

/// The encoding's name as a message says it ("ASCII", "UTF-8", "Windows-1252").
std::string_view to_string(TextEncoding e);

/// Whether `bytes` are valid UTF-8 (no overlong forms, no surrogates, at most U+10FFFF).
bool is_valid_utf8(std::string_view bytes);

/// Detects the encoding of `bytes` and returns them as UTF-8: UTF-16 (by its byte-order mark, or
/// by the NUL bytes its ASCII text has in every other place) decoded, its BOM dropped and an
/// unpaired surrogate read as U+FFFD; ASCII and UTF-8 unchanged; anything else decoded as Windows-1252 (bytes 0x81,
/// 0x8D, 0x8F, 0x90 and 0x9D, undefined there, as the Latin-1 control characters of the same value, so no byte is
/// lost).
std::string to_utf8(std::string bytes, TextEncoding* detected = nullptr);

/// Upper case of UTF-8 text for comparing labels: ASCII letters, and the letters of Latin-1 and
/// Latin Extended-A (é -> É, ö -> Ö, ł -> Ł), which French, German and Polish programs use; other
/// characters pass through (ß stays ß).
std::string upper_utf8(std::string_view text);

}  // namespace metron
