#pragma once

// An optional adaptor: a Model's topics as an Eigen matrix. model.hpp does not
// include Eigen; include this header where an Eigen matrix is wanted.

#include <Eigen/Core>

#include "rost/model.hpp"

namespace rost {

// phi (K x V): phi_k(v) = (n_k^v + beta) / (n_k + V beta), from the model's counts.
inline Eigen::MatrixXd topicModelMatrix(const Model& model) {
    const int K = model.K(), V = model.V();
    const double beta = model.config().beta, vb = V * beta;
    Eigen::MatrixXd phi(K, V);
    for (int v = 0; v < V; ++v)
        for (int k = 0; k < K; ++k) phi(k, v) = (model.topicWordCount(k, v) + beta) / (model.topicCount(k) + vb);
    return phi;
}

} // namespace rost
