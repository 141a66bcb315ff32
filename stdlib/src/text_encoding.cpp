// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/text_encoding.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>

namespace metron {
namespace {

// Windows-1252 bytes 0x80..0x9F as Unicode code points (the Unicode consortium's
// bestfit1252 / WHATWG encoding table); 0 marks the five undefined bytes.
constexpr std::array<std::uint16_t, 32> cp1252_high = {0x20AC, 0,      0x201A, 0x0192, 0x201E, 0x2026, 0x2020, 0x2021,
                                                       0x02C6, 0x2030, 0x0160, 0x2039, 0x0152, 0,      0x017D, 0,
                                                       0,      0x2018, 0x2019, 0x201C, 0x201D, 0x2022, 0x2013, 0x2014,
                                                       0x02DC, 0x2122, 0x0161, 0x203A, 0x0153, 0,      0x017E, 0x0178};

void append_utf8(std::string& out, std::uint32_t cp) {
  if (cp < 0x80) {
    out.push_back(static_cast<char>(cp));
  } else if (cp < 0x800) {
    out.push_back(static_cast<char>(0xC0 | (cp >> 6)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else if (cp < 0x10000) {
    out.push_back(static_cast<char>(0xE0 | (cp >> 12)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else {
    out.push_back(static_cast<char>(0xF0 | (cp >> 18)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 12) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  }
}

// UTF-16 without a BOM: in its first bytes, the text's ASCII characters put a NUL in every other
// place (odd places little-endian, even places big-endian) and none in the others.
std::optional<bool> utf16_by_nuls(std::string_view bytes) {
  const std::size_t n = std::min<std::size_t>(bytes.size(), 256) & ~std::size_t{1};
  if (n < 4) return std::nullopt;
  std::size_t even = 0, odd = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (bytes[i] == '\0') ++(i % 2 == 0 ? even : odd);
  if (odd * 10 >= n / 2 * 9 && even == 0) return true;   // little-endian
  if (even * 10 >= n / 2 * 9 && odd == 0) return false;  // big-endian
  return std::nullopt;
}

std::string utf16_to_utf8(std::string_view bytes, bool little_endian) {
  std::string out;
  out.reserve(bytes.size() / 2);
  const auto unit = [&](std::size_t i) {
    const auto a = static_cast<unsigned char>(bytes[i]), b = static_cast<unsigned char>(bytes[i + 1]);
    return static_cast<std::uint32_t>(little_endian ? a | (b << 8) : (a << 8) | b);
  };
  constexpr std::uint32_t replacement = 0xFFFD;
  for (std::size_t i = 0; i + 1 < bytes.size(); i += 2) {
    const std::uint32_t u = unit(i);
    if (u >= 0xD800 && u <= 0xDBFF && i + 3 < bytes.size()) {
      const std::uint32_t low = unit(i + 2);
      if (low >= 0xDC00 && low <= 0xDFFF) {
        append_utf8(out, 0x10000 + ((u - 0xD800) << 10) + (low - 0xDC00));
        i += 2;
        continue;
      }
    }
    append_utf8(out, u >= 0xD800 && u <= 0xDFFF ? replacement : u);
  }
  if (bytes.size() % 2) append_utf8(out, replacement);  // a lone last byte
  return out;
}

}  // namespace

std::string_view to_string(TextEncoding e) {
  switch (e) {
    case TextEncoding::Ascii: return "ASCII";
    case TextEncoding::Utf8: return "UTF-8";
    case TextEncoding::Windows1252: return "Windows-1252";
    case TextEncoding::Utf16Le: return "UTF-16LE";
    case TextEncoding::Utf16Be: return "UTF-16BE";
  }
  return "?";
}

bool is_valid_utf8(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;
    std::uint32_t cp = 0, min = 0;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xE0) == 0xC0) {
      n = 1;
      cp = c & 0x1F;
      min = 0x80;
    } else if ((c & 0xF0) == 0xE0) {
      n = 2;
      cp = c & 0x0F;
      min = 0x800;
    } else if ((c & 0xF8) == 0xF0) {
      n = 3;
      cp = c & 0x07;
      min = 0x10000;
    } else
      return false;
    for (std::size_t k = 1; k <= n; ++k) {
      if (i + k >= s.size()) return false;
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += n + 1;
  }
  return true;
}

std::string to_utf8(std::string bytes, TextEncoding* detected) {
  const bool bom_le =
      bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0xFF && static_cast<unsigned char>(bytes[1]) == 0xFE;
  const bool bom_be =
      bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0xFE && static_cast<unsigned char>(bytes[1]) == 0xFF;
  const std::optional<bool> by_nuls = bom_le || bom_be ? std::nullopt : utf16_by_nuls(bytes);
  if (bom_le || bom_be || by_nuls) {
    const bool little = bom_le || (by_nuls && *by_nuls);
    if (detected) *detected = little ? TextEncoding::Utf16Le : TextEncoding::Utf16Be;
    return utf16_to_utf8(std::string_view(bytes).substr(bom_le || bom_be ? 2 : 0), little);
  }
  bool ascii = true;
  for (const char c : bytes)
    if (static_cast<unsigned char>(c) >= 0x80) {
      ascii = false;
      break;
    }
  if (ascii || is_valid_utf8(bytes)) {
    if (detected) *detected = ascii ? TextEncoding::Ascii : TextEncoding::Utf8;
    return bytes;
  }
  if (detected) *detected = TextEncoding::Windows1252;
  // Windows-1252, line by line: a line that is UTF-8 with characters beyond ASCII stays UTF-8 (a
  // generator pasting UTF-8 names into a Windows-1252 template writes both in one file, and one
  // label would be two otherwise).
  std::string out;
  out.reserve(bytes.size() + bytes.size() / 8);
  std::size_t begin = 0;
  while (begin < bytes.size()) {
    const std::size_t nl = bytes.find('\n', begin);
    const std::size_t end = nl == std::string::npos ? bytes.size() : nl + 1;
    const std::string_view line(bytes.data() + begin, end - begin);
    const bool beyond_ascii =
        std::any_of(line.begin(), line.end(), [](char c) { return static_cast<unsigned char>(c) >= 0x80; });
    if (beyond_ascii && is_valid_utf8(line)) {
      out.append(line);
    } else {
      for (const char ch : line) {
        const auto c = static_cast<unsigned char>(ch);
        if (c < 0x80)
          out.push_back(ch);
        else if (c < 0xA0 && cp1252_high[c - 0x80] != 0)
          append_utf8(out, cp1252_high[c - 0x80]);
        else
          append_utf8(out, c);
      }
    }
    begin = end;
  }
  return out;
}

std::string upper_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 'a' && c <= 'z') {
      out += static_cast<char>(c - 'a' + 'A');
      continue;
    }
    if ((c == 0xC3 || c == 0xC4 || c == 0xC5) && i + 1 < text.size() &&
        (static_cast<unsigned char>(text[i + 1]) & 0xC0) == 0x80) {
      unsigned cp = ((c & 0x1Fu) << 6) | (static_cast<unsigned char>(text[i + 1]) & 0x3Fu);
      if (cp >= 0xE0 && cp <= 0xFE && cp != 0xF7)
        cp -= 0x20;  // à..þ (not ÷)
      else if (cp == 0xFF)
        cp = 0x178;  // ÿ
      else if (((cp >= 0x100 && cp <= 0x137) || (cp >= 0x14A && cp <= 0x177)) && (cp & 1u))
        cp -= 1;
      else if (((cp >= 0x139 && cp <= 0x148) || (cp >= 0x179 && cp <= 0x17E)) && !(cp & 1u))
        cp -= 1;
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3Fu));
      ++i;
      continue;
    }
    out += static_cast<char>(c);
  }
  return out;
}

}  // namespace metron
