// rtusim: the command line of the rtu toolkit. One subcommand per job; `rtusim SUBCOMMAND --help` for each.
#include <cstdio>
#include <exception>

#include "host/cmd/common.h"
#include "host/error.h"

int main(int argc, char** argv) {
  CLI::App app{"rtusim: a model of a fixed-function ray-tracing unit (float reference, scenes, rays, hits)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "rtusim 0.1.0");
  rtu::host::cmd::add_info(app);
  rtu::host::cmd::add_rays(app);
  rtu::host::cmd::add_trace(app);
  rtu::host::cmd::add_compare(app);
  rtu::host::cmd::add_stress(app);
  rtu::host::cmd::add_render(app);
  rtu::host::cmd::add_diff(app);
  rtu::host::cmd::add_config(app);
  rtu::host::cmd::add_demo(app);
  rtu::host::cmd::add_sweep(app);
  rtu::host::cmd::add_plan(app);
  rtu::host::cmd::add_report(app);
  rtu::host::cmd::add_soak(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const rtu::host::ExitStatus& e) {
    return e.code();
  } catch (const rtu::host::Error& e) {
    std::fprintf(stderr, "rtusim: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtusim: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
