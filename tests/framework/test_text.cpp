// abbreviate / printable / csv_text: untrusted text kept bounded, on one line and valid UTF-8.
#include <cstdlib>
#include <fstream>

#include "study_helpers.hpp"
#include "varbo/csv.hpp"
#include "varbo/text.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("abbreviate keeps both ends and says how much is left out") {
  CHECK(abbreviate("short", 1024) == "short");
  const std::string big = "<" + std::string(100000, 'x') + ">";
  const std::string a = abbreviate(big, 1024);
  CHECK(a.size() < 2 * 1024 + 64);
  CHECK(a.front() == '<');
  CHECK(a.back() == '>');
  CHECK(a.find("[... 97954 bytes omitted ...]") != std::string::npos);  // 100002 - 2·1024
  // A cut never splits a character: "é" is 2 bytes, so 1024 bytes would end inside one.
  std::string accents;
  for (int i = 0; i < 5000; ++i) accents += "\xC3\xA9";
  const std::string b = abbreviate("a" + accents, 1024);
  CHECK(printable(b) == b);  // still valid UTF-8 (printable changes nothing in valid, control-free text)
}

TEST_CASE("printable: valid UTF-8 kept, controls and invalid bytes escaped") {
  CHECK(printable("plain, \"quoted\" text") == "plain, \"quoted\" text");
  CHECK(printable("\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80") == "\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80");  // é € 😀
  CHECK(printable("a\nb\rc\td") == "a\\nb\\rc\\td");
  CHECK(printable(std::string("\x00\x1b\x7f", 3)) == "\\x00\\x1B\\x7F");
  CHECK(printable("\xFF\xFE") == "\\xFF\\xFE");
  CHECK(printable("\xC0\xAF") == "\\xC0\\xAF");            // overlong '/'
  CHECK(printable("\xED\xA0\x80") == "\\xED\\xA0\\x80");   // a UTF-16 surrogate
  CHECK(printable("\xF4\x90\x80\x80") == "\\xF4\\x90\\x80\\x80");  // above U+10FFFF
  CHECK(printable("ok\xE2\x82") == "ok\\xE2\\x82");        // truncated at the end
}

TEST_CASE("csv_text: one valid UTF-8 cell whatever the input") {
  CHECK(csv_text("simple") == "simple");
  CHECK(csv_text("a,b") == "\"a,b\"");
  CHECK(csv_text("say \"hi\"") == "\"say \"\"hi\"\"\"");
  CHECK(csv_text("two\nlines") == "two\\nlines");
  // Every byte value, checked by an independent decoder (iconv) once written to a file.
  std::string all;
  for (int c = 0; c < 256; ++c) all += static_cast<char>(c);
  const std::string file = test::temp_folder("csv_text") + "/cell.csv";
  std::ofstream(file) << csv_text(all) << "\n";
  CHECK(std::system(("iconv -f UTF-8 -t UTF-8 " + file + " >/dev/null 2>&1").c_str()) == 0);
  std::ifstream in(file);
  std::string line;
  int lines = 0;
  while (std::getline(in, line)) ++lines;
  CHECK(lines == 1);
}
