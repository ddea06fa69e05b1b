// terrain-server: configuration, store, built-in scenes, then HTTP until SIGINT/SIGTERM.
#include <sys/resource.h>

#include <boost/asio/signal_set.hpp>

#include <iostream>
#include <thread>

#include "server/app.hpp"
#include "server/log.hpp"
#include "server/net.hpp"
#include "server/store.hpp"

int main(int argc, char** argv) {
  std::vector<std::string_view> args(argv + 1, argv + argc);
  auto startup = server::load_config(args, server::process_environment());
  if (!startup) {
    std::cerr << "terrain-server: " << startup.error().pointer << ": " << startup.error().message
              << "\n";
    return 2;
  }
  if (startup->show_help) {
    std::cout << server::help_text();
    return 0;
  }
  const server::Config& config = startup->config;
  // Cached tiles are sent from sealed in-memory files, a descriptor each (server/sealed_file.hpp):
  // take every descriptor the system allows this process, not the shell's default soft limit.
  if (rlimit files{}; ::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
    files.rlim_cur = files.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &files);
  }
  server::set_log_level(config.log_level);
  auto store = server::open_store(config);
  if (!store) {
    std::cerr << "terrain-server: store: " << store.error().message << "\n";
    return 1;
  }
  server::App app(config, std::move(store).value());
  if (terrain::Status seeded = app.seed_examples(); !seeded) {
    std::cerr << "terrain-server: built-in scenes: " << seeded.error().message << "\n";
    return 1;
  }
  server::HttpServer http(app, config);
  auto port = http.listen();
  if (!port) {
    std::cerr << "terrain-server: " << port.error().message << "\n";
    return 1;
  }
  // Signals are waited for on a thread of their own so that shutdown never depends on a free
  // I/O thread.
  boost::asio::io_context signals_io;
  boost::asio::signal_set signals(signals_io, SIGINT, SIGTERM);
  signals.async_wait([&](const boost::system::error_code& ec, int signal) {
    if (ec) return;
    server::log(server::LogLevel::info, "shutdown", {{"signal", signal}});
    http.stop();
  });
  std::thread signal_thread([&] { signals_io.run(); });
  // The PostgreSQL URL is not printed: it may carry a password.
  const std::string where = config.store_backend == server::StoreBackend::sqlite
                                ? "data " + config.data_dir
                                : "store postgres";
  std::cout << "terrain-server listening on http://" << config.address << ":" << *port << " ("
            << where << ")" << std::endl;
  server::log(server::LogLevel::info, "backend",
              {{"choice", server::backend_name(config.backend)}, {"using", app.backend_reason()}});
  http.run();
  signals_io.stop();
  signal_thread.join();
  std::cerr << "terrain-server: stopped\n";
  return 0;
}
