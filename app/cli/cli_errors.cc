#include "app/cli/cli_errors.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "app/cli/cli_checks.h"

namespace hapticlab::app {
namespace {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::vector<std::string> command_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(sub->get_name());
  return names;
}

// "hapticlab study show": the commands the parser got into.
std::string command_path(CLI::App& app) {
  std::string path = "hapticlab";  // not argv[0], which may be a path
  CLI::App* current = &app;
  for (;;) {
    const std::vector<CLI::App*> parsed = current->get_subcommands();
    if (parsed.empty()) break;
    current = parsed.front();
    path += " " + current->get_name();
  }
  return path;
}

// An unknown command word, found before CLI11 parses (its own message,
// "The following arguments were not expected", names neither the command
// level nor a likely fix). Options end the walk: only groups of commands
// are walked, and they take no options besides --help.
int check_command_words(CLI::App& app, int argc, char** argv) {
  CLI::App* current = &app;
  std::string path = "hapticlab";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') return 0;
    const std::vector<std::string> names = command_names(*current);
    if (names.empty()) return 0;  // a command: the rest are its arguments
    CLI::App* next = nullptr;
    try {
      next = current->get_subcommand(word);
    } catch (const CLI::OptionNotFound&) {
    }
    if (next == nullptr) {
      std::string message = "hapticlab: error: '" + word + "' is not a " + (current == &app ? "" : path + " ") +
                            "command";
      const std::string near = nearest_name(word, names);
      if (!near.empty()) message += "; did you mean '" + near + "'?";
      std::fprintf(stderr, "%s\nRun '%s --help' for the list of commands.\n", message.c_str(), path.c_str());
      return 2;
    }
    current = next;
    path += " " + word;
  }
  return 0;
}

}  // namespace

std::string exit_status_help() {
  return "Exit status: 0 success; 1 the command failed (the message says what and where); 2 usage error "
         "(unknown command or option, bad value); 3 a device fault ended the run (session run, sim run, "
         "sim replay); 4 sim run: the task did not complete in time; 130 stopped by Ctrl-C (session run, demo: "
         "run it again to continue; sim run, sim replay: nothing written).\nMore: hapticlab help COMMAND, or hapticlab COMMAND --help.";
}

std::string nearest_name(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = 0;
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (best.empty() || d < best_distance) {
      best = c;
      best_distance = d;
    }
  }
  // A typo changes a few letters; beyond about a third of the word it is
  // another word, and a suggestion would only mislead.
  const std::size_t allowed = std::max<std::size_t>(2, word.size() / 3);
  return !best.empty() && best_distance <= allowed ? best : std::string();
}

void add_help_command(CLI::App& app) {
  CLI::App* help = app.add_subcommand("help", "Show the help of a command: hapticlab help [COMMAND...]");
  auto words = std::make_shared<std::vector<std::string>>();
  help->add_option("command", *words, "A command, e.g. `study create`");
  help->callback([&app, help, words] {
    CLI::App* target = &app;
    std::string path = "hapticlab", parent;
    for (const std::string& word : *words) {
      CLI::App* next = nullptr;
      try {
        next = target->get_subcommand(word);
      } catch (const CLI::OptionNotFound&) {
      }
      if (next == nullptr || next == help) {
        const std::string near = nearest_name(word, command_names(*target));
        throw CLI::ValidationError("help", "'" + word + "' is not a " + (target == &app ? "" : path + " ") +
                                               "command" + (near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
      target = next;
      parent = path;
      path += " " + word;
    }
    // help() appends the command's own name to the prefix it is given.
    // App::help() of a parent follows the command being parsed (this one),
    // so the top level's help comes from the formatter.
    const std::string text = target == &app ? app.get_formatter()->make_help(&app, "hapticlab", CLI::AppFormatMode::Normal)
                                            : target->help(parent);
    std::fputs(text.c_str(), stdout);
  });
}

namespace {

// What a command printed reaches a file or a pipe only when the buffer is
// written: a full disk (`> /dev/full`) or an error of the file under `>`
// left the output incomplete, which exit status 0 would hide.
int with_stdout_checked(int status) {
  std::cout.flush();
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;
  const int error = errno;
  if (flushed && !std::ferror(stdout) && std::cout.good()) return status;
  std::fprintf(stderr, "hapticlab: error: cannot write to standard output%s; what the command printed is incomplete\n",
               error != 0 ? (std::string(" (") + std::strerror(error) + ")").c_str() : "");
  return status == 0 ? 1 : status;
}

// CLI11 names an option by get_name(), which is empty for a hidden one (an
// old spelling, app/cli/renamed_option.h; a positional kept for an old
// form), so its errors read ": File does not exist: x" or " excludes
// --csv". The hidden options the user gave, in the command being parsed,
// are the candidates; with one, its name goes where CLI11 left it out.
std::string with_hidden_option_named(CLI::App& app, const std::string& what) {
  if (what.empty() || (what[0] != ':' && what[0] != ' ')) return what;
  CLI::App* current = &app;
  for (std::vector<CLI::App*> parsed = app.get_subcommands(); !parsed.empty(); parsed = current->get_subcommands()) {
    current = parsed.front();
  }
  std::vector<std::string> given;
  for (const CLI::Option* option : current->get_options()) {
    if (!option->get_group().empty() || option->count() == 0) continue;
    given.push_back(option->get_lnames().empty() ? option->get_single_name() : "--" + option->get_lnames().front());
  }
  return given.size() == 1 ? given.front() + what : what;
}

int parse_and_run(CLI::App& app, int argc, char** argv) {
  if (argc == 1) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  }
  if (const int status = check_command_words(app, argc, argv); status != 0) return status;
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a command's own status; it printed its message
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version (CLI11 derives them from Success)
  } catch (const CLI::ParseError& e) {
    const std::string path = command_path(app);
    const std::string what = dynamic_cast<const CLI::ArgumentMismatch*>(&e) != nullptr
                                 ? argument_mismatch_text(app, e.what())
                                 : with_hidden_option_named(app, e.what());
    std::fprintf(stderr, "hapticlab: error: %s\nRun '%s --help' for usage.\n", what.c_str(), path.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hapticlab: error: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

int run_command_line(CLI::App& app, int argc, char** argv) {
  return with_stdout_checked(parse_and_run(app, argc, argv));
}

}  // namespace hapticlab::app
