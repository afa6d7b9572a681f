// rtusim: the command line of the rtu toolkit. One subcommand per job; `rtusim SUBCOMMAND --help` for each.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/jobs/model_identity.h"

namespace {

// Every floating-point option of every subcommand refuses NaN, naming the option: CLI11's range checks compare,
// and NaN passes every comparison (--background nan rendered garbage, --scale nan meant "the default").
void refuse_nan(CLI::App& app) {
  for (CLI::Option* opt : app.get_options())
    if (opt->get_type_name().find("FLOAT") != std::string::npos) {
      const std::string name = opt->get_name();
      opt->check(CLI::Validator(
          [name](std::string& v) {
            const double x = std::strtod(v.c_str(), nullptr);
            return std::isnan(x) ? std::string("NaN is not a value") : std::string();
          },
          "", "not NaN"));
    }
  for (CLI::App* sub : app.get_subcommands({})) refuse_nan(*sub);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rtusim: a model of a fixed-function ray-tracing unit (float reference, scenes, rays, hits)"};
  app.require_subcommand(1);
  // The model identity names the build: sweep point keys hold it (host/jobs/model_identity.h).
  app.set_version_flag("--version", std::string("rtusim 0.1.0 (model ") + rtu::host::model_identity() + ")");
  namespace cli = rtu::host::cli;
  // The subcommands, in the order --help lists them.
  for (void (*add)(CLI::App&) :
       {cli::add_info, cli::add_rays, cli::add_trace, cli::add_compare, cli::add_stress, cli::add_render,
        cli::add_diff, cli::add_config, cli::add_demo, cli::add_sweep, cli::add_plan, cli::add_report,
        cli::add_soak, cli::add_motion, cli::add_query, cli::add_join})
    add(app);
  refuse_nan(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage error (unknown option, bad value, missing or conflicting options)
    // prints CLI11's message and exits 2, as bad input does (docs/guide/hardening.md), not with CLI11's codes.
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const rtu::host::ExitStatus& e) {
    return e.code();
  } catch (const rtu::host::Error& e) {
    std::fprintf(stderr, "rtusim: error: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    // A path no estimate covers took more than the machine gave: say so, and what bounds it.
    std::fprintf(stderr, "rtusim: error: %s\n",
                 rtu::host::out_of_memory_message(std::string("rtusim ") + (argc > 1 ? argv[1] : "")).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtusim: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
