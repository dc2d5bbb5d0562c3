/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

\*---------------------------------------------------------------------------*/

#include "tqProjected.H"
#include "Time.H"
#include "PstreamReduceOps.H"
#include "addToRunTimeSelectionTable.H"

#include <type_traits>

static_assert
(
    std::is_same<Foam::solveScalar, Foam::scalar>::value,
    "tqProjected is written for solveScalar == scalar (the default build)"
);

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
    defineTypeNameAndDebug(projectionHistory, 0);
    defineTypeNameAndDebug(tqProjected, 0);

    lduMatrix::solver::addsymMatrixConstructorToTable<tqProjected>
        addtqProjectedSymMatrixConstructorToTable_;
}
}


// * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * * //

namespace
{

using Foam::label;
using Foam::scalar;
using Foam::scalarField;

//- out[j] = a[j] . b on this rank
void localDots
(
    const std::vector<scalarField>& a,
    const scalarField& b,
    scalarField& out
)
{
    out.setSize(label(a.size()));
    for (size_t j = 0; j < a.size(); ++j)
    {
        out[label(j)] = Foam::sumProd(a[j], b);
    }
}

//- y -= sum_j c[j] a[j]
void subtractCombination
(
    const std::vector<scalarField>& a,
    const scalarField& c,
    scalarField& y
)
{
    const label n = y.size();
    scalar* __restrict__ yp = y.data();
    for (size_t j = 0; j < a.size(); ++j)
    {
        const scalar cj = c[label(j)];
        const scalar* __restrict__ ap = a[j].cdata();
        for (label i = 0; i < n; ++i)
        {
            yp[i] -= cj*ap[i];
        }
    }
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tq::projectionHistory::projectionHistory(const IOobject& io)
:
    regIOobject(io),
    sign(0),
    q()
{}


Foam::tq::projectionHistory& Foam::tq::projectionHistory::lookupOrStore
(
    const objectRegistry& db,
    const word& name
)
{
    projectionHistory* h = db.getObjectPtr<projectionHistory>(name);
    if (h)
    {
        return *h;
    }
    return regIOobject::store
    (
        new projectionHistory
        (
            IOobject
            (
                name,
                db.time().timeName(),
                db,
                IOobject::NO_READ,
                IOobject::NO_WRITE,
                true
            )
        )
    );
}


Foam::tq::tqProjected::tqProjected
(
    const word& fieldName,
    const lduMatrix& matrix,
    const FieldField<Field, scalar>& interfaceBouCoeffs,
    const FieldField<Field, scalar>& interfaceIntCoeffs,
    const lduInterfaceFieldPtrsList& interfaces,
    const dictionary& solverControls
)
:
    lduMatrix::solver
    (
        fieldName,
        matrix,
        interfaceBouCoeffs,
        interfaceIntCoeffs,
        interfaces,
        solverControls
    ),
    innerDict_(),
    nVectors_(controlDict_.lookupOrDefault<label>("vectors", 32))
{
    if (!controlDict_.isDict("inner"))
    {
        FatalIOErrorInFunction(controlDict_)
            << "solver " << typeName << " for " << fieldName
            << " needs a sub-dictionary 'inner' with the solver that takes"
            << " the projected start to the tolerances, e.g." << nl
            << "    inner { solver GAMG; smoother GaussSeidel; }"
            << exit(FatalIOError);
    }
    innerDict_ = controlDict_.subDict("inner");
    if (innerDict_.lookupOrDefault<word>("solver", word::null) == typeName)
    {
        FatalIOErrorInFunction(innerDict_)
            << "The inner solver of " << typeName << " for " << fieldName
            << " cannot be " << typeName << " itself: use GAMG or PCG."
            << exit(FatalIOError);
    }
    if (nVectors_ < 1 || nVectors_ > 100)
    {
        FatalIOErrorInFunction(controlDict_)
            << "vectors " << nVectors_ << " for " << fieldName
            << ": the number of earlier increments projected onto must be"
            << " between 1 and 100 (32: the paper's water, docs/water.md)."
            << exit(FatalIOError);
    }
}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

Foam::tq::projectionHistory* Foam::tq::tqProjected::history() const
{
    const lduMesh& m = matrix_.mesh();
    if (!m.hasDb())
    {
        return nullptr;
    }
    return &projectionHistory::lookupOrStore
    (
        m.thisDb(),
        word("tqProjected(" + fieldName_ + ')')
    );
}


Foam::scalar Foam::tq::tqProjected::dot
(
    const scalarField& a,
    const scalarField& b
) const
{
    return gSumProd(a, b, matrix_.mesh().comm());
}


Foam::scalar Foam::tq::tqProjected::removeSpan
(
    const projectionHistory& h,
    const scalarField& v,
    const scalar f,
    scalarField& w
) const
{
    if (!h.size())
    {
        return 0;
    }
    scalarField c;
    localDots(h.q, v, c);
    reduce(c, sumOp<scalarField>(), Pstream::msgType(), matrix_.mesh().comm());
    c *= f;
    subtractCombination(h.q, c, w);
    return sumSqr(c);
}


void Foam::tq::tqProjected::extend
(
    projectionHistory& h,
    const scalarField& d,
    const scalarField& Ad,
    const direction cmpt
) const
{
    const scalar dAd = dot(d, Ad);
    if (h.sign == 0)
    {
        if (dAd == 0)
        {
            return;
        }
        h.sign = dAd < 0 ? -1 : 1;
    }
    const scalar s = h.sign;
    const scalar norm0 = s*dAd;
    if (!(norm0 > 0))
    {
        return;  // d = 0, or A not definite along d
    }

    // Classical Gram-Schmidt in the A-inner product.  By symmetry
    // q_j . A w needs no stored A q_j, and for A-orthonormal q_j the part
    // left has |w|_A^2 = |d|_A^2 - sum beta_j^2.  A second pass when the
    // first removed more than half of |d|_A^2 ("twice is enough", Kahan):
    // otherwise the directions drift from orthogonality when the increments
    // are nearly dependent, and the projection goes wrong (seen on the
    // closed slice); it takes A w afresh.
    scalarField w(d);
    scalar norm = norm0 - removeSpan(h, Ad, s, w);
    if (h.size() && !(norm > 0.5*norm0))
    {
        scalarField Aw(w.size());
        matrix_.Amul(Aw, tmp<scalarField>(w), interfaceBouCoeffs_, interfaces_, cmpt);
        norm = s*dot(w, Aw) - removeSpan(h, Aw, s, w);
    }
    if (!(norm > 1e-10*norm0))
    {
        return;  // d lies in the span already (to round-off)
    }
    w *= 1/Foam::sqrt(norm);
    h.q.push_back(std::move(w));
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::solverPerformance Foam::tq::tqProjected::solve
(
    scalarField& psi,
    const scalarField& source,
    const direction cmpt
) const
{
    const label comm = matrix_.mesh().comm();
    const label n = psi.size();

    solverPerformance perf(typeName, fieldName_);

    // The incoming field's residual: the reference of relTol, as in any
    // OpenFOAM solver
    scalarField Ax(n);
    matrix_.Amul(Ax, tmp<scalarField>(psi), interfaceBouCoeffs_, interfaces_, cmpt);
    scalarField r(n);
    const scalar nf = normFactor(psi, source, Ax, r);
    r = source - Ax;
    const scalar r1 = gSumMag(r, comm);
    perf.initialResidual() = r1/nf;
    perf.finalResidual() = perf.initialResidual();

    if (minIter_ <= 0 && perf.checkConvergence(tolerance_, relTol_))
    {
        return perf;
    }
    // Absolute target on sum |b - A x|
    const scalar target = max(tolerance_*nf, relTol_*r1);

    projectionHistory* h = history();
    if (h && h->size() && h->q.front().size() != n)
    {
        h->q.clear();  // another mesh: start again
    }
    const label nUsed = h ? h->size() : 0;

    // The incoming field and its product, kept when the basis is full: it
    // then restarts from this step's whole increment
    scalarField psi0;
    scalarField Apsi0;
    if (nUsed >= nVectors_)
    {
        psi0 = psi;
        Apsi0 = Ax;
    }

    // Start: psi corrected within the span of the earlier increments,
    // x0 = psi + sum_j (s q_j . r) q_j (the A-norm best start in psi + span),
    // if its residual is below psi's
    scalar r01 = r1;
    bool inSpan = false;  // whether psi - psi0 lies in the span
    if (nUsed)
    {
        scalarField x0(psi);
        removeSpan(*h, r, -h->sign, x0);
        scalarField Ax0(n);
        matrix_.Amul(Ax0, tmp<scalarField>(x0), interfaceBouCoeffs_, interfaces_, cmpt);
        const scalar r0 = gSumMag((source - Ax0)(), comm);
        if (r0 < r1)
        {
            psi.transfer(x0);
            Ax.transfer(Ax0);
            r01 = r0;
            inSpan = true;
        }
        else
        {
            // The span no longer predicts the step (the matrix changed
            // more than the stored directions allow): start it again
            h->q.clear();
        }
    }

    label nInner = 0;
    scalar rFinal1 = r01;
    scalarField xStart;   // the inner solver's start and its product
    scalarField AxStart;
    if (minIter_ > 0 || !(r01 < target))
    {
        xStart = psi;
        AxStart = Ax;
        dictionary d(innerDict_);
        d.set("tolerance", scalar(0));
        d.set("relTol", max(target/max(r01, VSMALL), scalar(1e-12)));
        d.set("maxIter", maxIter_);
        d.set("minIter", minIter_);
        const solverPerformance inner =
            lduMatrix::solver::New
            (
                fieldName_,
                matrix_,
                interfaceBouCoeffs_,
                interfaceIntCoeffs_,
                interfaces_,
                d
            )->solve(psi, source, cmpt);
        nInner = inner.nIterations();
        perf.solverName() = typeName + ':' + inner.solverName();

        matrix_.Amul(Ax, tmp<scalarField>(psi), interfaceBouCoeffs_, interfaces_, cmpt);
        rFinal1 = gSumMag((source - Ax)(), comm);
        inSpan = inSpan && nInner == 0;
    }

    perf.nIterations() = nInner;
    perf.finalResidual() = rFinal1/nf;
    perf.checkConvergence(tolerance_, relTol_);

    // The basis takes this step's increment: what lies outside the span,
    // the inner solver's correction (the projected start is in the span;
    // the correction alone leaves less to cancel than the whole increment;
    // without a usable span the inner solver started from the incoming
    // field, so the correction is the whole increment); a full basis
    // restarts from the whole increment.  Not in the span means the inner
    // solver ran.
    if (h && !inSpan)
    {
        if (h->size() >= nVectors_)
        {
            h->q.clear();
            extend(*h, (psi - psi0)(), (Ax - Apsi0)(), cmpt);
        }
        else
        {
            extend(*h, (psi - xStart)(), (Ax - AxStart)(), cmpt);
        }
    }

    if (debug)
    {
        Info<< typeName << ": " << fieldName_ << " incoming " << r1/nf
            << ", projected (" << nUsed << " directions) "
            << r01/nf << ", target " << target/nf << ", final " << rFinal1/nf
            << ", inner iterations " << nInner << endl;
    }

    return perf;
}


// ************************************************************************* //
