// pseudo_terminal::link(): a symlink is made only where nothing is, or in place of a stale
// link to a pty that is gone; a file, a directory, another symlink and the link of a pty that
// is open are refused and left as they were. The link goes with the pty only while it is
// still the pty's.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <system_error>

#include "ferrule/host/pseudo_terminal.hpp"

namespace host = ferrule::host;
namespace fs = std::filesystem;

namespace {

// A fresh directory, removed with everything in it.
struct scratch_dir {
    scratch_dir() {
        std::string t = "/tmp/ferrule-pty-XXXXXX";
        REQUIRE(::mkdtemp(t.data()) != nullptr);
        path = t;
    }
    ~scratch_dir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
    std::string operator/(const char* name) const { return path + "/" + name; }
    std::string path;
};

void write_file(const std::string& path, const std::string& text) {
    std::ofstream(path) << text;
}

std::string contents(const std::string& path) {
    std::ifstream in(path);
    return {std::istreambuf_iterator<char>(in), {}};
}

bool exists_at(const std::string& path) {
    struct stat st {};
    return ::lstat(path.c_str(), &st) == 0;
}

// A /dev/pts name that no pty has now.
std::string gone_pty() {
    for (int n = 999'999;; --n)
        if (const auto p = "/dev/pts/" + std::to_string(n); !fs::exists(p)) return p;
}

struct opened_pty {
    opened_pty() { REQUIRE_FALSE(pty.open()); }
    host::pseudo_terminal pty;
};

} // namespace

TEST_CASE("pseudo_terminal link is made where nothing is and goes with the pty", "[asio][pty]") {
    scratch_dir dir;
    const auto link = dir / "bus";
    {
        opened_pty a;
        REQUIRE_FALSE(a.pty.link(link));
        CHECK(host::read_link(link) == a.pty.path());
    }
    CHECK_FALSE(exists_at(link));
}

TEST_CASE("pseudo_terminal link refuses what is not a stale link and leaves it", "[asio][pty]") {
    scratch_dir dir;
    const auto file = dir / "file";
    write_file(file, "x\n");
    const auto subdir = dir / "subdir";
    fs::create_directory(subdir);
    const auto to_file = dir / "to-file";
    fs::create_symlink(file, to_file);
    const auto dangling = dir / "dangling"; // dangling, but not into /dev/pts
    fs::create_symlink(dir / "nothing", dangling);
    {
        opened_pty a;
        CHECK(a.pty.link(file) == std::errc::file_exists);
        CHECK(a.pty.link(subdir) == std::errc::file_exists);
        CHECK(a.pty.link(to_file) == std::errc::file_exists);
        CHECK(a.pty.link(dangling) == std::errc::file_exists);
        CHECK(host::link_refusal(file, std::make_error_code(std::errc::file_exists)) ==
              file + " is a regular file, not a stale simulator link; left as it is");
        CHECK(host::link_refusal(subdir, std::make_error_code(std::errc::file_exists)) ==
              subdir + " is a directory, not a stale simulator link; left as it is");
        CHECK(host::link_refusal(to_file, std::make_error_code(std::errc::file_exists)) ==
              to_file + " is a symlink to " + file + ", not a stale simulator link; left as it is");
    }
    // Nothing was touched, at the refusal or when the pty went.
    CHECK(contents(file) == "x\n");
    CHECK(fs::is_directory(subdir));
    CHECK(host::read_link(to_file) == file);
    CHECK(host::read_link(dangling) == dir / "nothing");
}

TEST_CASE("pseudo_terminal link of an open pty is refused; its holder keeps it", "[asio][pty]") {
    scratch_dir dir;
    const auto link = dir / "bus";
    std::optional<opened_pty> first;
    first.emplace();
    REQUIRE_FALSE(first->pty.link(link));
    {
        opened_pty second;
        const auto ec = second.pty.link(link);
        CHECK(ec == std::errc::device_or_resource_busy);
        CHECK(host::link_refusal(link, ec) ==
              link + " is a symlink to " + first->pty.path() +
                  ", a pseudo-terminal in use (another simulator's?); left as it is");
    }
    // The second pty's end took nothing with it.
    CHECK(host::read_link(link) == first->pty.path());
    first.reset();
    CHECK_FALSE(exists_at(link));
    // Free again: the next pty links there.
    opened_pty third;
    REQUIRE_FALSE(third.pty.link(link));
    CHECK(host::read_link(link) == third.pty.path());
}

TEST_CASE("pseudo_terminal link takes the place of a stale link", "[asio][pty]") {
    scratch_dir dir;
    const auto link = dir / "bus";
    SECTION("to a pty that is gone") {
        fs::create_symlink(gone_pty(), link);
        opened_pty a;
        REQUIRE_FALSE(a.pty.link(link));
        CHECK(host::read_link(link) == a.pty.path());
    }
    SECTION("to the very pty, its number given again") {
        opened_pty a;
        fs::create_symlink(a.pty.path(), link);
        REQUIRE_FALSE(a.pty.link(link));
        CHECK(host::read_link(link) == a.pty.path());
    }
    CHECK_FALSE(exists_at(link));
}

TEST_CASE("pseudo_terminal leaves what took its link's place", "[asio][pty]") {
    scratch_dir dir;
    const auto link = dir / "bus";
    const auto other = dir / "other";
    SECTION("a file") {
        {
            opened_pty a;
            REQUIRE_FALSE(a.pty.link(link));
            REQUIRE(::unlink(link.c_str()) == 0);
            write_file(link, "mine\n");
        }
        CHECK(contents(link) == "mine\n");
    }
    SECTION("another link") {
        {
            opened_pty a;
            REQUIRE_FALSE(a.pty.link(link));
            REQUIRE(::unlink(link.c_str()) == 0);
            fs::create_symlink(other, link);
        }
        CHECK(host::read_link(link) == other);
    }
}

TEST_CASE("pseudo_terminal link names pseudo-terminals by their /dev/pts path", "[asio][pty]") {
    CHECK(host::is_pty_name("/dev/pts/0"));
    CHECK(host::is_pty_name("/dev/pts/17"));
    CHECK_FALSE(host::is_pty_name("/dev/pts/"));
    CHECK_FALSE(host::is_pty_name("/dev/pts/ptmx"));
    CHECK_FALSE(host::is_pty_name("/dev/pts/1/x"));
    CHECK_FALSE(host::is_pty_name("/dev/ttyUSB0"));
    CHECK_FALSE(host::is_pty_name("../dev/pts/1"));
}
