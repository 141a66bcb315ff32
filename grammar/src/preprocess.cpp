// SPDX-License-Identifier: GPL-3.0-or-later
// Logical lines: `$` continuations joined, `$$` comments (and continued comments) removed.
#include "metron/grammar/preprocess.hpp"

#include <utility>
#include <vector>

namespace metron::grammar {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// Index of the last non-blank byte in [begin, end), or `end` when there is none.
std::size_t last_non_blank(const std::string& s, std::size_t begin, std::size_t end) {
  for (std::size_t i = end; i > begin; --i)
    if (!is_blank(s[i - 1])) return i - 1;
  return end;
}

// A comment `$$ ...` in [begin, end) continues onto the next line when it ends in a single `$`;
// `$$$$$$` banners (the last `$` preceded by another `$`) do not.
bool comment_continues(const std::string& s, std::size_t begin, std::size_t end) {
  const std::size_t last = last_non_blank(s, begin, end);
  return last != end && s[last] == '$' && last > begin && s[last - 1] != '$';
}

class Joiner {
 public:
  explicit Joiner(const std::string& source) : m_src(source) {}

  std::vector<LogicalLine> run() {
    // A UTF-8 byte order mark (written by some Windows editors) is not part of the first line.
    std::size_t pos = m_src.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
    const std::size_t n = m_src.size();
    while (pos < n) {
      const auto [end, next] = physical_line(pos);
      if (!m_continued && !m_comment_continues && text_statement(pos, end)) {
        pos = text_block(pos, end, next);
        continue;
      }
      line(pos, end);
      pos = next;
    }
    flush();
    return std::move(m_out);
  }

 private:
  /// The end of the physical line starting at `pos` (without its terminator) and where the next starts.
  std::pair<std::size_t, std::size_t> physical_line(std::size_t pos) const {
    const std::size_t nl = m_src.find('\n', pos);
    const std::size_t next = nl == std::string::npos ? m_src.size() : nl + 1;
    std::size_t end = nl == std::string::npos ? m_src.size() : nl;
    if (end > pos && m_src[end - 1] == '\r') --end;
    return {end, next};
  }

  /// A letter, digit or byte of a UTF-8 character: a quote between two of them is an apostrophe.
  static bool word_byte(char c) {
    const auto u = static_cast<unsigned char>(c);
    return u >= 0x80 || (c >= '0' && c <= '9') || (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
  }

  /// Scans [begin, end) for strings, an apostrophe staying inside one: whether the line has an
  /// apostrophe, and whether a string is still open at its end.
  struct Quotes {
    bool apostrophe = false;
    bool open_at_end = false;
  };
  Quotes scan_quotes(std::size_t begin, std::size_t end) const {
    Quotes q;
    bool in_string = false;
    for (std::size_t i = begin; i < end; ++i) {
      if (m_src[i] != '\'') continue;
      if (!in_string) {
        in_string = true;
      } else if (i + 1 < end && m_src[i + 1] == '\'') {
        ++i;  // a doubled quote
      } else if (i > begin && i + 1 < end && word_byte(m_src[i - 1]) && word_byte(m_src[i + 1])) {
        q.apostrophe = true;
      } else {
        in_string = false;
      }
    }
    q.open_at_end = in_string;
    return q;
  }

  /// A TEXT statement's line, not continued by `$`, with an apostrophe in its string or a string
  /// still open at the end of the line.
  bool text_statement(std::size_t begin, std::size_t end) const {
    while (begin < end && is_blank(m_src[begin])) ++begin;
    if (end - begin < 6) return false;
    std::string head = m_src.substr(begin, 5);
    for (char& c : head) c = static_cast<char>(c >= 'a' && c <= 'z' ? c - 32 : c);
    if (head != "TEXT/") return false;
    const std::size_t last = last_non_blank(m_src, begin, end);
    if (last == end || m_src[last] == '$' || m_src.find("$$", begin) < end) return false;
    const Quotes q = scan_quotes(begin, end);
    return q.apostrophe || q.open_at_end;
  }

  /// CMM software writes an operator's text as it was typed: apostrophes inside it, over several
  /// lines (CAMIO: `TEXT/OPER,'Mettre l'échelle en place;` ... `et en butée vers la gauche'`).
  /// When a TEXT line does not end in a quote and one of the next lines (10 at most) does, the
  /// lines are one statement, their line breaks kept inside the string. A quote between two
  /// letters or digits (l'échelle) is an apostrophe: it is doubled, DMIS's quote in a string.
  /// Returns where the next statement starts.
  std::size_t text_block(std::size_t begin, std::size_t end, std::size_t next) {
    std::vector<std::pair<std::size_t, std::size_t>> lines{{begin, end}};
    std::size_t after = next;
    auto ends_in_quote = [&](std::size_t b, std::size_t e) {
      const std::size_t last = last_non_blank(m_src, b, e);
      return last != e && m_src[last] == '\'' && last > m_src.find('\'', begin);
    };
    const bool open = scan_quotes(begin, end).open_at_end;
    while (open && !ends_in_quote(lines.back().first, lines.back().second)) {
      if (after >= m_src.size() || lines.size() > 10) {  // no closing line: as it is
        lines.resize(1);
        after = next;
        break;
      }
      const auto [e, n] = physical_line(after);
      lines.push_back({after, e});
      after = n;
    }
    for (std::size_t k = 0; k < lines.size(); ++k) {
      if (k > 0) append(lines[k - 1].second, lines[k].first);  // the line break, inside the string
      append(lines[k].first, lines[k].second);
    }
    LogicalLine out;
    for (std::size_t i = 0; i < m_cur.text.size(); ++i) {
      out.text.push_back(m_cur.text[i]);
      out.physical.push_back(m_cur.physical[i]);
      if (m_cur.text[i] == '\'' && i > 0 && i + 1 < m_cur.text.size() && word_byte(m_cur.text[i - 1]) &&
          word_byte(m_cur.text[i + 1])) {
        out.text.push_back('\'');  // an apostrophe: doubled
        out.physical.push_back(m_cur.physical[i]);
      }
    }
    m_cur = std::move(out);
    flush();
    return after;
  }

  // One physical line [begin, end) without its line terminator.
  void line(std::size_t begin, std::size_t end) {
    if (m_comment_continues) {  // the previous line was a comment ending in a single `$`
      m_comment_continues = comment_continues(m_src, begin, end);
      return;
    }
    // The blanks that start a continued line are not part of the statement: shop software
    // splits long lines anywhere, even inside a label (`FA(CIR_$` / `   1)` is FA(CIR_1)).
    if (m_continued && !m_in_string) {
      while (begin < end && is_blank(m_src[begin])) ++begin;
      // A blank line after a `$` does not end the statement: the continuation goes on to the
      // next line with text (web pages and mail double-space pasted programs).
      if (begin == end) return;
    }
    m_continued = false;
    // Find where a `$$` comment starts; `$$` inside a quoted string is text. The string state
    // carries over continuation lines because a continuation may split a string.
    std::size_t code_end = end;
    for (std::size_t i = begin; i < end; ++i) {
      const char c = m_src[i];
      if (m_in_string) {
        if (c == '\'') {
          if (i + 1 < end && m_src[i + 1] == '\'')
            ++i;
          else
            m_in_string = false;
        }
      } else if (c == '\'') {
        m_in_string = true;
      } else if (c == '$' && i + 1 < end && m_src[i + 1] == '$') {
        code_end = i;
        break;
      }
    }
    const std::size_t last = last_non_blank(m_src, begin, code_end);
    if (last != code_end && m_src[last] == '$') {
      // Continuation: drop the `$`, what follows it and the newline; the next line is appended.
      append(begin, last);
      m_continued = true;
      return;
    }
    append(begin, code_end);
    if (code_end != end) m_comment_continues = comment_continues(m_src, code_end, end);
    flush();
  }

  void append(std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      m_cur.text.push_back(m_src[i]);
      m_cur.physical.push_back(static_cast<std::uint32_t>(i));
    }
  }

  void flush() {
    const bool blank = last_non_blank(m_cur.text, 0, m_cur.text.size()) == m_cur.text.size();
    if (!blank) {
      m_cur.physical.push_back(m_cur.physical.back() + 1);
      m_out.push_back(std::move(m_cur));
    }
    m_cur = LogicalLine{};
    m_in_string = false;
  }

  const std::string& m_src;
  std::vector<LogicalLine> m_out;
  LogicalLine m_cur;
  bool m_in_string = false;
  bool m_comment_continues = false;
  bool m_continued = false;  // the previous physical line ended in a continuation `$`
};

}  // namespace

std::vector<LogicalLine> join_continuations(const std::string& source) { return Joiner(source).run(); }

}  // namespace metron::grammar
