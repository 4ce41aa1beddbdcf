#pragma once
/// @file WorkerThread.h
/// Internal to the AVATAR libraries (not installed): one long-lived thread
/// that runs the tasks handed to it, one after the other, so that no thread is
/// created per frame. The analysis runs the right image's share of a stage on
/// one; the replay backend reads the next pair on one while the current pair
/// is analysed.

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <utility>

namespace avatar::detail {

class WorkerThread {
public:
    WorkerThread() : thread_([this] { loop(); }) {}
    /// Runs the tasks already submitted, then joins.
    ~WorkerThread() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stop_ = true;
        }
        wake_.notify_one();
        thread_.join();
    }
    WorkerThread(const WorkerThread&) = delete;
    WorkerThread& operator=(const WorkerThread&) = delete;

    /// Queues @p work; its result (or exception) arrives in the future.
    template <typename F>
    auto submit(F work) -> std::future<decltype(work())> {
        using R = decltype(work());
        auto task = std::make_shared<std::packaged_task<R()>>(std::move(work));
        std::future<R> done = task->get_future();
        {
            std::lock_guard<std::mutex> lock(mutex_);
            queue_.emplace_back([task] { (*task)(); });
        }
        wake_.notify_one();
        return done;
    }

private:
    void loop() {
        for (;;) {
            std::function<void()> task;
            {
                std::unique_lock<std::mutex> lock(mutex_);
                wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
                if (queue_.empty()) return;
                task = std::move(queue_.front());
                queue_.pop_front();
            }
            task();  // a packaged_task: exceptions land in its future
        }
    }

    std::mutex mutex_;
    std::condition_variable wake_;
    std::deque<std::function<void()>> queue_;
    bool stop_{false};
    std::thread thread_;  ///< last: started once the members above exist
};

}  // namespace avatar::detail
