#include "python/interrupt.h"

#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>

#include <pybind11/pybind11.h>

namespace hrad::python {

namespace py = pybind11;

void runInterruptible(const std::function<void(CancelToken&)>& work) {
    CancelToken token;
    std::exception_ptr failure;
    std::optional<py::error_already_set> interrupt;  // KeyboardInterrupt, held with the GIL
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    {
        py::gil_scoped_release release;
        std::thread worker([&] {
            try {
                work(token);
            } catch (...) {
                failure = std::current_exception();
            }
            std::lock_guard<std::mutex> lock(mutex);
            done = true;
            finished.notify_all();
        });
        std::unique_lock<std::mutex> lock(mutex);
        while (!done) {
            finished.wait_for(lock, std::chrono::milliseconds(50));
            if (done || interrupt) continue;
            lock.unlock();
            {
                py::gil_scoped_acquire gil;
                if (PyErr_CheckSignals() != 0) {
                    interrupt.emplace();  // fetches the pending exception
                    token.request();
                }
            }
            lock.lock();
        }
        lock.unlock();
        worker.join();
    }
    if (interrupt) throw *interrupt;
    if (failure) std::rethrow_exception(failure);
}

}  // namespace hrad::python
