#include "core/text.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

namespace mca::text {

std::string num(double v) {
  const double a = std::fabs(v);
  if (std::isfinite(v) && a != 0.0 && (a >= 1e5 || a < 1e-3)) {
    for (int p = 0; p <= 17; ++p) {
      std::string s = fmt::format("{:.{}e}", v, p);
      if (std::strtod(s.c_str(), nullptr) != v) continue;
      // fmt pads the exponent to two digits ("1.5e-04"); TOML allows it, people do not write it.
      const std::size_t e = s.find('e');
      const std::size_t d = e + 2;
      while (d + 1 < s.size() && s[d] == '0') s.erase(d, 1);
      if (s[e + 1] == '+') s.erase(e + 1, 1);
      return s;
    }
  }
  return fmt::format("{}", v);
}

Distinct distinct(double a, double b, int digits) {
  for (int p = digits;; ++p) {
    Distinct d{fmt::format("{:.{}g}", a, p), fmt::format("{:.{}g}", b, p)};
    if (d.a != d.b || a == b || p >= 17) return d;
  }
}

namespace {
// x to `digits` significant digits, moved one unit of the last digit down (`down`) or up where the rounding
// went past x.
std::string rounded(double x, int digits, bool down) {
  std::string s = fmt::format("{:.{}g}", x, digits);
  if (!std::isfinite(x) || x == 0) return s;
  for (int tries = 0; tries < 3; ++tries) {
    const double v = std::strtod(s.c_str(), nullptr);
    if (down ? v <= x : v >= x) return s;
    const double unit = std::pow(10.0, std::floor(std::log10(std::fabs(v))) - digits + 1);
    s = fmt::format("{:.{}g}", down ? v - unit : v + unit, digits);
  }
  return s;
}
}  // namespace

std::string at_most(double x, int digits) { return rounded(x, digits, true); }
std::string at_least(double x, int digits) { return rounded(x, digits, false); }

std::string escaped(std::string_view s) {
  std::string out;
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\t': out += "\\t"; break;
      case '\n': out += "\\n"; break;
      case '\f': out += "\\f"; break;
      case '\r': out += "\\r"; break;
      default:
        if (is_control(ch)) {
          out += fmt::format("\\u{:04X}", static_cast<unsigned>(c));
        } else {
          out += ch;
        }
    }
  }
  return out;
}

std::string quoted(std::string_view s) {
  // Appended in turn: "\"" + escaped(s) draws a false -Wrestrict from g++ 12.
  std::string out = "\"";
  out += escaped(s);
  out += '"';
  return out;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& ch : out) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return out;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                        std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (same ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates) {
  const std::string* best = nullptr;
  std::size_t best_d = std::string::npos;
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = &c;
    }
  }
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  return best && best_d <= limit ? fmt::format("; did you mean '{}'?", *best) : std::string();
}

std::string suggestion(std::string_view word, const std::vector<std::string>& candidates) {
  std::string s = did_you_mean(word, candidates);
  if (!s.empty()) return s;
  // Each once, in order (a scene's own "concrete" shadows the built-in one of that name).
  std::vector<std::string_view> once;
  for (const auto& c : candidates)
    if (std::find(once.begin(), once.end(), c) == once.end()) once.push_back(c);
  return fmt::format("; allowed: {}", fmt::join(once, ", "));
}

std::string number_runs(const std::vector<std::int64_t>& sorted, std::size_t most) {
  std::string out;
  std::size_t runs = 0, k = 0;
  for (; k < sorted.size() && runs < most; ++runs) {
    std::size_t end = k;
    while (end + 1 < sorted.size() && sorted[end + 1] == sorted[end] + 1) ++end;
    out += fmt::format("{}{}", runs ? ", " : "", sorted[k]);
    if (end > k) out += fmt::format("{}{}", end == k + 1 ? ", " : "..", sorted[end]);
    k = end + 1;
  }
  if (k < sorted.size()) out += fmt::format(", and {} more", sorted.size() - k);
  return out;
}

std::string count(std::uint64_t n, std::string_view word) {
  const std::size_t bar = word.find('|');
  const std::string_view one = word.substr(0, bar);
  if (n == 1) return fmt::format("1 {}", one);
  return bar == std::string_view::npos ? fmt::format("{} {}s", n, one) : fmt::format("{} {}", n, word.substr(bar + 1));
}

std::string human_bytes(double bytes) {
  const char* units[] = {"bytes", "KB", "MB", "GB", "TB", "PB", "EB"};
  int u = 0;
  while (bytes >= 999.5 && u < 6) {
    bytes /= 1000;
    ++u;
  }
  return u == 0 ? fmt::format("{:.0f} bytes", bytes) : fmt::format("{:.3g} {}", bytes, units[u]);
}

std::string sim_time(double seconds, double resolution) {
  const bool in_seconds = resolution > 0 ? resolution >= 0.1 : std::abs(seconds) >= 10;
  const double unit = in_seconds ? 1.0 : 1e3;
  const double step = unit * (resolution > 0 ? resolution : std::abs(seconds) / 100);
  int decimals = 2;
  if (step > 0 && std::isfinite(step))
    decimals = static_cast<int>(std::clamp(std::ceil(-std::log10(step) + 0.5), 2.0, 12.0));  // (0.0025 ms: 4)
  return fmt::format("{:.{}f} {}", unit * seconds, decimals, in_seconds ? "s" : "ms");
}

std::string shell_word(std::string_view s) {
  const bool plain = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::string_view("_-./+,:=@%").find(c) != std::string_view::npos;
  });
  if (plain) return std::string(s);
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

namespace {
// The length of the UTF-8 sequence at s[i], or 0 where the bytes there are not one.
std::size_t utf8_length(std::string_view s, std::size_t i) {
  const auto c = static_cast<unsigned char>(s[i]);
  const std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
  if (n == 0 || i + n > s.size()) return 0;
  std::uint32_t cp = n == 1 ? c : c & (0x7f >> n);
  for (std::size_t k = 1; k < n; ++k) {
    const auto t = static_cast<unsigned char>(s[i + k]);
    if ((t & 0xc0) != 0x80) return 0;
    cp = cp << 6 | (t & 0x3f);
  }
  // (overlong forms, UTF-16 surrogates and code points past U+10FFFF are not UTF-8)
  static constexpr std::uint32_t least[] = {0, 0, 0x80, 0x800, 0x10000};
  if (cp < least[n] || (cp >= 0xd800 && cp <= 0xdfff) || cp > 0x10ffff) return 0;
  return n;
}
}  // namespace

bool is_utf8(std::string_view s) {
  for (std::size_t i = 0, n; i < s.size(); i += n)
    if ((n = utf8_length(s, i)) == 0) return false;
  return true;
}

std::string utf8_shown(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    const std::size_t n = utf8_length(s, i);
    if (n) {
      out.append(s.substr(i, n));
      i += n;
    } else {
      out += fmt::format("\\x{:02x}", static_cast<unsigned char>(s[i]));
      ++i;
    }
  }
  return out;
}

int wide_unicode_bom(std::string_view head) {
  if (head.substr(0, 4) == std::string_view("\xFF\xFE\0\0", 4) || head.substr(0, 4) == std::string_view("\0\0\xFE\xFF", 4))
    return 32;
  return head.substr(0, 2) == "\xFF\xFE" || head.substr(0, 2) == "\xFE\xFF" ? 16 : 0;
}

}  // namespace mca::text
