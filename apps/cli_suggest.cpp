#include "cli_suggest.hpp"

#include <algorithm>
#include <vector>

namespace burrbench::apps {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  // Damerau–Levenshtein (optimal string alignment): a swapped pair is one edit.
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

namespace {

// The nearest candidate within a third of the word's length (at least 1, at most 3 edits),
// or a candidate the word is a prefix of.
std::string nearest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::min<std::size_t>(3, std::max<std::size_t>(1, word.size() / 3)) + 1;
  for (const auto& c : candidates) {
    const std::size_t dist = (word.size() >= 3 && c.rfind(word, 0) == 0) ? 1 : edit_distance(word, c);
    if (dist < best_d) {
      best_d = dist;
      best = c;
    }
  }
  return best;
}

std::string with_hint(std::string msg, const std::string& near) {
  return near.empty() ? msg : msg + " (did you mean " + near + "?)";
}

}  // namespace

std::string explain_parse_error(const CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
  // The verb chain the user named (e.g. "rig check"), and the options it knows.
  const CLI::App* cur = &app;
  std::string chain;
  int i = 1;
  for (; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("-", 0) == 0) break;
    const CLI::App* sub = nullptr;
    for (const auto* s : cur->get_subcommands([](const CLI::App*) { return true; }))
      if (s->get_name() == a) sub = s;
    if (!sub) {
      // A word where a verb is expected (and this level has verbs) is an unknown verb.
      std::vector<std::string> verbs;
      for (const auto* s : cur->get_subcommands([](const CLI::App*) { return true; })) verbs.push_back(s->get_name());
      if (!verbs.empty())
        return with_hint((chain.empty() ? "" : chain + ": ") + "unknown command '" + a + "'", nearest(a, verbs)) +
               "; run `burrbench " + (chain.empty() ? "" : chain + " ") + "--help` for the list";
      break;
    }
    cur = sub;
    chain += (chain.empty() ? "" : " ") + a;
  }
  std::vector<std::string> options{"--help"};
  for (const auto* o : cur->get_options())
    for (const auto& l : o->get_lnames()) options.push_back("--" + l);
  for (int k = i; k < argc; ++k) {
    std::string a = argv[k];
    if (a == "--") break;
    if (a.rfind("--", 0) != 0) continue;
    a = a.substr(0, a.find('='));
    if (std::find(options.begin(), options.end(), a) == options.end())
      return with_hint((chain.empty() ? "" : chain + ": ") + "unknown option " + a, nearest(a, options)) +
             "; run `burrbench " + (chain.empty() ? "" : chain + " ") + "--help` for the options";
  }
  return (chain.empty() ? "" : chain + ": ") + std::string(e.what()) + "; run `burrbench " +
         (chain.empty() ? "" : chain + " ") + "--help` for the usage";
}

}  // namespace burrbench::apps
