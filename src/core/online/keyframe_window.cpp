#include "tescalib/core/online/keyframe_window.h"

#include <algorithm>

#include <Eigen/Eigenvalues>

#include "tescalib/core/common/geometry.h"

namespace tescalib {

KeyframeWindow::KeyframeWindow(int size, const std::string& selection)
    : size_(size), by_information_(selection == "information") {}

std::vector<double> KeyframeWindow::stamps() const {
  std::vector<double> stamps;
  for (const auto& k : keyframes_) stamps.push_back(k->stamp);
  return stamps;
}

std::vector<std::shared_ptr<Keyframe>> KeyframeWindow::snapshot(bool deep_copies) const {
  std::vector<std::shared_ptr<Keyframe>> out;
  for (const auto& k : keyframes_) out.push_back(deep_copies ? std::make_shared<Keyframe>(*k) : k);
  return out;
}

void KeyframeWindow::add(std::shared_ptr<Keyframe> keyframe) {
  keyframes_.push_back(std::move(keyframe));
  if (!oldest_first_) {
    trim(&keyframes_);
    return;
  }
  while (static_cast<int>(keyframes_.size()) > std::max(1, size_)) {
    set_aside_.push_back(keyframes_.front());
    keyframes_.pop_front();
  }
  trim(&set_aside_);
}

void KeyframeWindow::trim(std::deque<std::shared_ptr<Keyframe>>* keyframes) {
  while (static_cast<int>(keyframes->size()) > std::max(1, size_)) {
    const size_t drop = keyframeToDrop(*keyframes);
    information_.erase((*keyframes)[drop]->stamp);
    keyframes->erase(keyframes->begin() + static_cast<long>(drop));
  }
}

void KeyframeWindow::setOldestFirst(bool on) {
  if (oldest_first_ && !on && !set_aside_.empty()) {
    keyframes_.insert(keyframes_.end(), set_aside_.begin(), set_aside_.end());
    std::stable_sort(keyframes_.begin(), keyframes_.end(),
                     [](const auto& a, const auto& b) { return a->stamp < b->stamp; });
    set_aside_.clear();
    trim(&keyframes_);
  }
  oldest_first_ = on;
}

void KeyframeWindow::clear() {
  keyframes_.clear();
  set_aside_.clear();
  information_.clear();
  oldest_first_ = false;
}

size_t KeyframeWindow::dropUpTo(double stamp) {
  for (auto* keyframes : {&keyframes_, &set_aside_}) {
    for (auto it = keyframes->begin(); it != keyframes->end();) {
      if ((*it)->stamp <= stamp) {
        information_.erase((*it)->stamp);
        it = keyframes->erase(it);
      } else {
        ++it;
      }
    }
  }
  return keyframes_.size();
}

void KeyframeWindow::storeInformation(const std::vector<std::shared_ptr<Keyframe>>& solved,
                                      const std::vector<Matrix6d>& information) {
  if (information.size() != solved.size()) return;
  // A keyframe set aside during the solve keeps what it measured, for when it comes back.
  for (size_t i = 0; i < solved.size(); ++i)
    for (const auto* keyframes : {&keyframes_, &set_aside_})
      for (const auto& k : *keyframes)
        if (k->stamp == solved[i]->stamp) information_[k->stamp] = information[i];
}

void KeyframeWindow::adoptRecomputedClouds(const std::vector<std::shared_ptr<Keyframe>>& solved) {
  // The window's keyframes are shared and never modified in place: the recomputed ones replace
  // them.
  for (const auto& k : solved)
    for (auto& w : keyframes_)
      if (w->stamp == k->stamp && !w->T_right_left_used.isApprox(k->T_right_left_used)) w = k;
}

size_t KeyframeWindow::keyframeToDrop(
    const std::deque<std::shared_ptr<Keyframe>>& keyframes) const {
  if (!by_information_) return 0;
  // Candidates: every keyframe but the newest that a solve has measured; the newest stays until
  // a solve has seen what it adds.
  std::vector<size_t> measured;
  Matrix6d total = Matrix6d::Zero();
  for (size_t i = 0; i + 1 < keyframes.size(); ++i) {
    const auto it = information_.find(keyframes[i]->stamp);
    if (it == information_.end()) continue;
    measured.push_back(i);
    total += it->second;
  }
  if (measured.size() < 2) return 0;
  // Information in units of the trust limits (0.1 deg, 1 cm), so that rotation and translation
  // compare; the weakest direction is the smallest eigenvalue of what remains after a drop.
  Vector6d scale;
  scale << Vector6d::Constant(0.1 / kDegPerRad).head<3>(), Vector6d::Constant(0.01).tail<3>();
  const Matrix6d S = scale.asDiagonal();
  auto weakest = [&](const Matrix6d& H) {
    return Eigen::SelfAdjointEigenSolver<Matrix6d>(S * H * S).eigenvalues()(0);
  };
  double best = -1;
  std::vector<double> remaining(measured.size());
  for (size_t c = 0; c < measured.size(); ++c) {
    remaining[c] = weakest(total - information_.at(keyframes[measured[c]]->stamp));
    best = std::max(best, remaining[c]);
  }
  // The oldest keyframe whose loss keeps at least 95 % of the best achievable weakest-direction
  // information: recency wins among equals.
  for (size_t c = 0; c < measured.size(); ++c)
    if (remaining[c] >= 0.95 * best) return measured[c];
  return 0;
}

}  // namespace tescalib
