// ferrule: talk to drives and sensors on a serial port or over Modbus TCP, decode captures,
// run the demo.
// Exit codes: 0 ok, 1 the device reported an error, 2 usage, 3 timeout / transport error.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "commands.hpp"
#include "common.hpp"

int main(int argc, char** argv) {
    // Results on stdout and warnings, errors and --trace on stderr often share one terminal,
    // pipe or log: a line-buffered stdout puts each line out whole and in order with them.
    std::setvbuf(stdout, nullptr, _IOLBF, BUFSIZ);
    CLI::App app{"ferrule: the protocols PLCs use with drives and sensors, from a PC"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "ferrule 0.1.0");
    // Usage errors found while parsing look like those found after: "ferrule: --address: …".
    app.failure_message([](const CLI::App* a, const CLI::Error& e) {
        return "ferrule: " + CLI::FailureMessage::simple(a, e);
    });
    int exit_status = ferrule::cli::exit_ok;
    ferrule::cli::add_movilink(app, exit_status);
    ferrule::cli::add_dimetix(app, exit_status);
    ferrule::cli::add_lecom(app, exit_status);
    ferrule::cli::add_modbus(app, exit_status);
    ferrule::cli::add_profibus(app, exit_status);
    ferrule::cli::add_memobus(app, exit_status);
    ferrule::cli::add_decode(app, exit_status);
    ferrule::cli::add_demo(app, exit_status);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int rc = app.exit(e);
        return rc == 0 ? ferrule::cli::exit_ok : ferrule::cli::exit_usage;
    }
    return exit_status;
}
