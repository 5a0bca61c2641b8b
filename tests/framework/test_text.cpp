// abbreviate / printable / csv_text: untrusted text kept bounded, on one line and valid UTF-8.
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "study_helpers.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
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

TEST_CASE("read_csv: a BOM is dropped, another separator is named, a FIFO is refused (audit11a)") {
  const std::string dir = test::temp_folder("read_csv_hostile");
  const auto error_of = [&](const std::string& name, const std::string& text) -> std::string {
    std::ofstream(dir + "/" + name, std::ios::binary) << text;
    try {
      read_csv(dir + "/" + name);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  // A spreadsheet's UTF-8 byte order mark is not part of the first column's name ('y' was not found).
  std::ofstream(dir + "/bom.csv", std::ios::binary) << "\xEF\xBB\xBFy,x\n1,0\n";
  const CsvTable t = read_csv(dir + "/bom.csv");
  CHECK(t.column("y") == 0);
  CHECK(t.values.rows() == 1);
  // Semicolon- and tab-separated files were read as one column, and the error named a missing 'y'.
  CHECK(error_of("semi.csv", "x1;x2;y\n0.1;0.2;1.5\n")
            .find("semi.csv:1: the header is a single column 'x1;x2;y'; the line looks semicolon-separated") !=
        std::string::npos);
  CHECK(error_of("tab.csv", "x\ty\n0\t1\n").find("looks tab-separated") != std::string::npos);
  CHECK(error_of("row.csv", "x,y\n0;1\n").find("row.csv:2: expected 2 comma-separated values (as in the header), "
                                              "found 1; the line looks semicolon-separated") != std::string::npos);
  CHECK(error_of("one.csv", "y\n1\n").empty());  // one column without a separator is a table
  // A FIFO blocked forever (CLI11's ExistingFile accepts it); a device would be read without end.
  const std::string fifo = dir + "/fifo.csv";
  std::remove(fifo.c_str());
  REQUIRE(std::system(("mkfifo " + fifo).c_str()) == 0);
  CHECK_THROWS_WITH_AS(read_csv(fifo), (fifo + ": not a regular file (a FIFO; expected a CSV file)").c_str(), InputError);
}

TEST_CASE("terminal_text: escape sequences and C1 controls shown, never obeyed; lines and tabs kept") {
  // A parameter name of a study from elsewhere retitled and cleared the terminal through an error message
  // (red team, session 30): "\x1B]0;owned\x07\x1B[2J".
  CHECK(terminal_text("no parameter '\x1B]0;owned\x07\x1B[2J'") == "no parameter '\\x1B]0;owned\\x07\\x1B[2J'");
  CHECK(terminal_text("line one\n\tline two") == "line one\n\tline two");
  CHECK(terminal_text("csi \xC2\x9B" "2J and nel \xC2\x85") == "csi \\u009B2J and nel \\u0085");
  CHECK(terminal_text("caf\xC3\xA9 \xCE\xB8 \xE2\x80\x94 ok") == "caf\xC3\xA9 \xCE\xB8 \xE2\x80\x94 ok");  // é, θ, — stay
  // Characters a terminal shows as nothing or a blank, or that reorder the line (session 45): a name "x1" with a
  // zero-width space looked like "x1". No-break space, zero-width space, right-to-left override, byte order mark,
  // ideographic space (4-byte sequences are never among them: an emoji stays).
  CHECK(terminal_text("unknown parameter 'x\xE2\x80\x8B" "1'") == "unknown parameter 'x\\u200B1'");
  CHECK(terminal_text("a\xC2\xA0" "b") == "a\\u00A0b");
  CHECK(terminal_text("\xE2\x80\xAEtxt.exe") == "\\u202Etxt.exe");
  CHECK(terminal_text("\xEF\xBB\xBFkey \xE3\x80\x80") == "\\uFEFFkey \\u3000");
  CHECK(terminal_text("ok \xF0\x9F\x98\x80") == "ok \xF0\x9F\x98\x80");
  CHECK(terminal_text("bad \xFF byte\r") == "bad \\xFF byte\\r");
}

TEST_CASE("terminal_line: one line, escapes and C1 controls shown (a label printed by varbo suggest)") {
  // A categorical label "\x1B[2Jclear" cleared the screen of `varbo suggest`, "x\ny" split its line (session 31).
  CHECK(terminal_line("\x1B[2Jclear") == "\\x1B[2Jclear");
  CHECK(terminal_line("x\ny\tz") == "x\\ny\\tz");
  CHECK(terminal_line("csi \xC2\x9B" "2J") == "csi \\u009B2J");
  CHECK(terminal_line("gain_\xC3\xBC \xF0\x9F\xA4\x96") == "gain_\xC3\xBC \xF0\x9F\xA4\x96");  // ü and 🤖 stay
}

TEST_CASE("ASCII classes do not follow the process's locale") {
  // In a Latin-1 LC_CTYPE std::isalnum took both bytes of a UTF-8 'µ' (C2 B5) for letters (session 31).
  for (int c = 0; c < 256; ++c) {
    const char ch = static_cast<char>(c);
    const bool letter = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
    const bool digit = c >= '0' && c <= '9';
    CHECK(ascii_alpha(ch) == letter);
    CHECK(ascii_digit(ch) == digit);
    CHECK(ascii_alnum(ch) == (letter || digit));
    CHECK(ascii_space(ch) == (c == ' ' || (c >= 9 && c <= 13)));
  }
}

TEST_CASE("hide_url_passwords: a PostgreSQL URL's password is *** wherever it sits in a message") {
  // Audit, session 47: `varbo run --resume URL` wrote "resuming …: 14 finished trials read from
  // postgresql://lab:se$cret@127.0.0.1/…" into the run folder's log.txt.
  CHECK(hide_url_passwords("resuming r: 14 finished trials read from postgresql://lab:se$cret@127.0.0.1/varbo?study=a") ==
        "resuming r: 14 finished trials read from postgresql://lab:***@127.0.0.1/varbo?study=a");
  CHECK(hide_url_passwords("run `varbo abandon 'postgres://u:p%40ss@h:5432/db?study=s' --id 3`") ==
        "run `varbo abandon 'postgres://u:***@h:5432/db?study=s' --id 3`");
  CHECK(hide_url_passwords("postgresql:///db?host=/run/postgresql&password=hunter2&study=s and more") ==
        "postgresql:///db?host=/run/postgresql&password=***&study=s and more");
  CHECK(hide_url_passwords("postgresql://h/db?sslpassword=k3y&study=s") == "postgresql://h/db?sslpassword=***&study=s");
  // Twice in one message (an error and its hint).
  CHECK(hide_url_passwords("postgresql://a:b@h/d?study=x: created from … `varbo run --resume postgresql://a:b@h/d?study=x`") ==
        "postgresql://a:***@h/d?study=x: created from … `varbo run --resume postgresql://a:***@h/d?study=x`");
  // Nothing to hide: unchanged.
  for (const char* s : {"postgresql://lab@127.0.0.1/varbo?study=a", "postgresql:///varbo?host=/run/postgresql&study=a",
                        "runs/a/study.db: 3 trials", "user:pass@host without a scheme"})
    CHECK(hide_url_passwords(s) == s);
}
