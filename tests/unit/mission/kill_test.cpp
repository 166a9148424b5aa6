// kill -9 during appends: a child process appends journal records and syncs in a loop, reporting each
// synced count through a pipe; the parent SIGKILLs it at a seeded random moment and reopens the journal.
// Every record synced before the kill is there, every record read is exactly the one written at that
// position (nothing misread), and appending after recovery works.
#include "journal_fixture.hpp"
#include "test_support.hpp"
#include "vog/mission/journal.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

namespace vog::mission {
namespace {

// Record i of the child's deterministic sequence: waypoints, with a state change every 7th, and a
// loop closure (a long record) every 5th, so that stdio buffer flushes split records.
JournalRecord recordAt(std::uint64_t i) {
  if (i % 7 == 3) return MissionStateRecord{static_cast<std::int64_t>(i), MissionState::kPaused};
  if (i % 5 == 1) {
    std::mt19937_64 rng(i);
    return testing::sampleClosure(static_cast<std::int64_t>(i), static_cast<std::int64_t>(i + 1),
                                  1 + static_cast<int>(i % 6), rng);
  }
  const double v = static_cast<double>(i);
  return WaypointRecord{static_cast<std::int64_t>(i), v * 0.5, -v, 1.0 / (v + 1.0), v * 1e-3};
}

constexpr std::uint64_t kBlockedMarker = ~std::uint64_t{0};

// Appends and syncs in rounds, reporting the synced count after each. Every fourth round appends a
// batch larger than the 64 KiB stdio buffer, so that the buffer is flushed in the middle of a record
// before the sync. With `block_at_round` >= 0 the child stops in that round after appending and before
// syncing (it reports kBlockedMarker and waits forever), so the kill finds a torn record on disk.
[[noreturn]] void childLoop(const std::filesystem::path& path, int report_fd, int block_at_round) {
  auto journal = Journal::open(path);
  if (!journal) ::_exit(2);
  std::uint64_t n = 0;
  for (int round = 0; round < 100000; ++round) {
    const int batch = round % 4 == 3 ? 2000 : 1 + round % 9;
    for (int k = 0; k < batch; ++k) {
      if (!journal.value()->append(recordAt(n)).ok()) ::_exit(3);
      ++n;
    }
    if (round == block_at_round) {
      if (::write(report_fd, &kBlockedMarker, sizeof n) != static_cast<ssize_t>(sizeof n)) ::_exit(5);
      for (;;) ::pause();
    }
    if (!journal.value()->sync().ok()) ::_exit(4);
    if (::write(report_fd, &n, sizeof n) != static_cast<ssize_t>(sizeof n)) ::_exit(5);
  }
  ::_exit(0);
}

TEST(JournalKill, EverySyncedRecordSurvivesKill9AndNothingIsMisread) {
  std::mt19937_64 rng(20261122);
  int torn_tails = 0;
  for (int trial = 0; trial < 12; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    test::TempDir dir;
    const auto path = dir.path() / "journal.vogj";
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    // Even trials kill at a random moment; odd ones while the child waits between appending a large
    // batch and syncing it.
    const bool blocked = trial % 2 == 1;
    const int block_at_round = blocked ? 3 + 4 * (trial / 2) : -1;
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(fds[0]);
      childLoop(path, fds[1], block_at_round);
    }
    ::close(fds[1]);
    std::uint64_t synced = 0;
    std::uint64_t report = 0;
    if (blocked) {
      while (::read(fds[0], &report, sizeof report) == static_cast<ssize_t>(sizeof report) &&
             report != kBlockedMarker) {
        synced = report;
      }
    } else {
      // Wait until the child has synced at least once, then kill it after a random delay.
      ASSERT_EQ(::read(fds[0], &synced, sizeof synced), static_cast<ssize_t>(sizeof synced));
      std::this_thread::sleep_for(std::chrono::microseconds(std::uniform_int_distribution<int>(0, 30000)(rng)));
    }
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited early with status " << WEXITSTATUS(status);
    while (::read(fds[0], &report, sizeof report) == static_cast<ssize_t>(sizeof report)) {
      if (report != kBlockedMarker) synced = report;
    }
    ::close(fds[0]);

    auto got = readJournal(path);
    ASSERT_TRUE(got.ok()) << got.error().message;
    if (got->tail.torn) ++torn_tails;
    // A blocked child's unsynced batch reached the file only in whole 64 KiB buffer flushes, which
    // cut a record (record sizes do not divide the buffer): a torn tail must have been found.
    if (blocked) {
      EXPECT_TRUE(got->tail.torn);
    }
    ASSERT_GE(got->entries.size(), synced);
    for (std::size_t i = 0; i < got->entries.size(); ++i) {
      ASSERT_TRUE(testing::same(got->entries[i].record, recordAt(i))) << "record " << i;
    }
    // Recovery, then appending continues the sequence.
    JournalContents existing;
    auto journal = Journal::open(path, &existing);
    ASSERT_TRUE(journal.ok()) << journal.error().message;
    const std::size_t n = existing.entries.size();
    ASSERT_TRUE(journal.value()->append(recordAt(n)).ok());
    ASSERT_TRUE(journal.value()->sync().ok());
    journal.value().reset();
    auto after = readJournal(path);
    ASSERT_TRUE(after.ok());
    EXPECT_FALSE(after->tail.torn);
    ASSERT_EQ(after->entries.size(), n + 1);
    EXPECT_TRUE(testing::same(after->entries.back().record, recordAt(n)));
  }
  EXPECT_GE(torn_tails, 6);
  ::testing::Test::RecordProperty("torn_tails", torn_tails);
}

}  // namespace
}  // namespace vog::mission
