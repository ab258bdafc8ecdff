#pragma once
// Text for messages and scene files, shared by the scene reader and writer (src/io) and validate_scene
// (src/core), so that a number or a name reads the same in every message.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mca::text {

// A control character (C0 or DEL: NUL, tab, line breaks, ...), which names and paths in messages and files
// must not hold.
constexpr bool is_control(char ch) {
  const auto c = static_cast<unsigned char>(ch);
  return c < 0x20 || c == 0x7f;
}

// Shortest text that reads back as the same double; exponent form for large and tiny magnitudes
// (3e+10, 1.5e-4) so that moduli and strains stay readable.
std::string num(double v);

// `a` and `b` for a message that compares them, each to `digits` significant digits ("{:.4g}"), or to as
// many more as make them differ where they differ: a value just past a bound reads 0.02499997 against
// 0.025, not "0.025 is less than 0.025".
struct Distinct {
  std::string a, b;
};
Distinct distinct(double a, double b, int digits = 4);

// `x` to `digits` significant digits ("{:.6g}"), rounded down (at_most) or up (at_least): a bound a message
// advises ("lower output.frame_rate to at most 909090") must not be past it once rounded (909091 was
// refused again).
std::string at_most(double x, int digits);
std::string at_least(double x, int digits);

// `s` as the inside of a TOML basic string: quote, backslash and control characters escaped.
std::string escaped(std::string_view s);
// `s` as a TOML basic string: escaped(s) in double quotes.
std::string quoted(std::string_view s);

// `s` with its ASCII letters in lower case (the names of environment variables' values, file extensions).
std::string lower(std::string_view s);

// Levenshtein distance, letters compared without case.
std::size_t edit_distance(std::string_view a, std::string_view b);

// "; did you mean 'x'?" for the closest candidate within a third of the word's length (at least 2
// edits), else "; allowed: a, b, c" (each candidate once).
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates);
// The "; did you mean 'x'?" of suggestion, or "" when no candidate is close.
std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates);

// Sorted numbers as runs for a message: "0, 3..7, 12"; past `most` runs, ", and N more".
std::string number_runs(const std::vector<std::int64_t>& sorted, std::size_t most = 8);

// `n` and a noun for a message: "1 hole", "3 holes" (`word` takes an s, or gives its plural after a '|':
// "automaton|automata").
std::string count(std::uint64_t n, std::string_view word);

// A size for a message: "512 bytes", "430 KB", "1.72 TB" (3 digits; units of 1000).
std::string human_bytes(double bytes);

// A simulated time, "12.35 ms", with the decimals that show `resolution` seconds (the time between the frames
// shown; 0: three digits of `seconds` itself), at least two: a run of frames 10 ns apart read "0.00 ms" in
// every frame. In seconds where frames are 0.1 s or more apart (or, without a resolution, from 10 s on): frames
// 10 s apart read "20000.00 ms".
std::string sim_time(double seconds, double resolution = 0);

// Whether `s` is UTF-8 text (what TOML and JSON files hold): a path of a file system that takes any bytes
// may not be.
bool is_utf8(std::string_view s);
// `s` for a message: its UTF-8 as it is, each other byte as \xNN.
std::string utf8_shown(std::string_view s);

// 16 or 32 where `head` (a file's first bytes) starts with the byte order mark of UTF-16 or UTF-32 (FF FE, FE
// FF, FF FE 00 00, 00 00 FE FF), as some Windows programs save text; else 0.
int wide_unicode_bom(std::string_view head);

// `s` as one word of a POSIX shell's command line, for a command a message suggests: as it is where every
// character is a letter, digit or one of _ - . / + , : = @ %, else in single quotes ('my run', 'it'\''s').
std::string shell_word(std::string_view s);

}  // namespace mca::text
