/// @file eigen_sym3.hpp
/// @brief The eigen-decomposition of symmetric 3x3 matrices the Mohr–Coulomb return mapping uses:
///        cyclic Jacobi on one matrix, and the same on four at once (AVX2 without FMA, each lane the
///        one-matrix code's operations in its order, so each result is eigenSym3's bit for bit).
///        Internal to the solver's sources.
#pragma once

#include "tq/materials/material.hpp"

namespace tq {

/// Cyclic Jacobi of the symmetric s (Voigt): eval ascending, evec[:, i] (column i) its unit
/// eigenvector (accurate also for close or repeated eigenvalues).
void eigenSym3(const Real s[6], Real eval[3], Real evec[3][3]);

/// eigenSym3 of the four matrices s[q][l] (component q of matrix l) at once: eval[l], evec[l] as
/// eigenSym3 gives them. Call only where eigenSym3x4Available().
void eigenSym3x4(const Real (*s)[4], Real eval[4][3], Real evec[4][3][3]);

/// The CPU runs AVX2 and TQ_SOLID_SIMD is not `generic` (read once by the caller).
bool eigenSym3x4Available();

}  // namespace tq
