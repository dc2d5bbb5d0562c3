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

#include "tqInterpolatedDisplacementMotionSolver.H"
#include "interfaceTraction.H"
#include "addToRunTimeSelectionTable.H"
#include "globalIndex.H"
#include "ListListOps.H"
#include "primitiveFacePatch.H"
#include "treeDataPrimitivePatch.H"
#include "indexedOctree.H"
#include "treeBoundBox.H"
#include "triPointRef.H"
#include "Map.H"
#include "wordRes.H"

#include <cmath>

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
    defineTypeNameAndDebug(tqInterpolatedDisplacementMotionSolver, 0);

    addToRunTimeSelectionTable
    (
        motionSolver,
        tqInterpolatedDisplacementMotionSolver,
        dictionary
    );
}


// * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * * //

namespace
{

// Barycentric coordinates (for a, b, c) of the projection of x onto the plane
// of triangle (a, b, c), clamped to the triangle and renormalised.
Foam::FixedList<Foam::scalar, 3> clampedBarycentric
(
    const Foam::point& a,
    const Foam::point& b,
    const Foam::point& c,
    const Foam::point& x
)
{
    using namespace Foam;

    const vector v0(b - a);
    const vector v1(c - a);
    const vector v2(x - a);
    const scalar d00 = v0 & v0;
    const scalar d01 = v0 & v1;
    const scalar d11 = v1 & v1;
    const scalar d20 = v2 & v0;
    const scalar d21 = v2 & v1;
    const scalar denom = d00*d11 - d01*d01;

    FixedList<scalar, 3> lambda;
    if (mag(denom) < VSMALL)
    {
        lambda = 1.0/3.0;
        return lambda;
    }
    lambda[1] = max((d11*d20 - d01*d21)/denom, 0.0);
    lambda[2] = max((d00*d21 - d01*d20)/denom, 0.0);
    lambda[0] = max(1 - (d11*d20 - d01*d21)/denom - (d00*d21 - d01*d20)/denom, 0.0);
    const scalar sumL = lambda[0] + lambda[1] + lambda[2];
    for (scalar& l : lambda)
    {
        l /= sumL;
    }
    return lambda;
}

} // End anonymous namespace


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::tqInterpolatedDisplacementMotionSolver::calcWeights()
{
    const polyMesh& mesh = this->mesh();
    const pointField& p0 = points0();
    const polyBoundaryMesh& pbm = mesh.boundaryMesh();

    // Interface patches
    const wordRes patchNames(coeffDict().get<wordRes>("patches"));
    patchIDs_ = pbm.patchSet(patchNames).sortedToc();
    if (patchIDs_.empty())
    {
        FatalIOErrorInFunction(coeffDict())
            << "No patch matches 'patches' " << patchNames << nl
            << "Patches of the mesh: " << pbm.names() << nl
            << "Fix: name the interface patch(es) of the mesh."
            << exit(FatalIOError);
    }

    // This rank's interface points, faces in interface-point numbering
    boolList isInterface(mesh.nPoints(), false);
    DynamicList<label> iPoints;
    Map<label> meshToLocal;
    for (const label patchi : patchIDs_)
    {
        for (const label pointi : pbm[patchi].meshPoints())
        {
            if (!isInterface[pointi])
            {
                isInterface[pointi] = true;
                meshToLocal.insert(pointi, iPoints.size());
                iPoints.append(pointi);
            }
        }
    }
    interfacePoints_.transfer(iPoints);

    const globalIndex gi(interfacePoints_.size());
    globalOffset_ = gi.offset(Pstream::myProcNo());
    nGlobal_ = gi.size();

    DynamicList<face> iFaces;
    for (const label patchi : patchIDs_)
    {
        for (const face& f : pbm[patchi])
        {
            face g(f.size());
            forAll(f, k)
            {
                g[k] = globalOffset_ + meshToLocal[f[k]];
            }
            iFaces.append(g);
        }
    }

    // Gather the whole interface on every rank
    List<faceList> procFaces(Pstream::nProcs());
    procFaces[Pstream::myProcNo()].transfer(iFaces);
    Pstream::gatherList(procFaces);
    Pstream::scatterList(procFaces);
    const faceList gFaces
    (
        ListListOps::combine<faceList>(procFaces, accessOp<faceList>())
    );

    List<pointField> procPoints(Pstream::nProcs());
    procPoints[Pstream::myProcNo()] = pointField(p0, interfacePoints_);
    Pstream::gatherList(procPoints);
    Pstream::scatterList(procPoints);
    const pointField gPoints
    (
        ListListOps::combine<pointField>(procPoints, accessOp<pointField>())
    );

    if (gFaces.empty())
    {
        FatalErrorInFunction
            << "The interface patches " << patchNames << " have no faces."
            << exit(FatalError);
    }

    // Area weights of the interface points (for the mean displacement)
    {
        const List<scalarList> w(tq::medianDualWeights(gFaces, gPoints));
        scalarField faceAreas(gFaces.size());
        forAll(gFaces, facei)
        {
            faceAreas[facei] = gFaces[facei].mag(gPoints);
        }
        globalAreaWeight_ =
            tq::pointAreas(gFaces, w, gPoints.size(), faceAreas);
        globalAreaWeight_ /= sum(globalAreaWeight_);
    }

    // Nearest interface face of every other mesh point
    const primitiveFacePatch gPatch(gFaces, gPoints);
    // Box over the whole mesh (contains the interface), slightly enlarged
    // and asymmetric so that faces do not align with octree cubes
    treeBoundBox bb(p0);
    {
        const scalar tol = 1e-6*bb.avgDim();
        bb.min() -= point(tol, tol, tol);
        bb.max() += point(2*tol, 2*tol, 2*tol);
    }
    typedef treeDataPrimitivePatch<primitiveFacePatch> treeType;
    const indexedOctree<treeType> tree
    (
        treeType(false, gPatch, indexedOctree<treeType>::perturbTol()),
        bb,
        10,     // maxLevel
        10,     // leafSize
        3.0     // duplicity
    );
    const scalar searchDistSqr = magSqr(bb.span());

    DynamicList<label> moved(mesh.nPoints());
    DynamicList<label> start(mesh.nPoints() + 1);
    DynamicList<label> sPoint(4*mesh.nPoints());
    DynamicList<scalar> sWeight(4*mesh.nPoints());
    DynamicList<scalar> dist(mesh.nPoints());

    forAll(p0, pointi)
    {
        if (isInterface[pointi])
        {
            continue;
        }
        const point& x = p0[pointi];
        const pointIndexHit hit = tree.findNearest(x, searchDistSqr);
        if (!hit.hit())
        {
            FatalErrorInFunction
                << "No interface face found near point " << pointi
                << " at " << x << exit(FatalError);
        }
        const face& f = gFaces[hit.index()];
        const point& h = hit.hitPoint();
        const point c = f.centre(gPoints);

        // Triangle (c, p_k, p_k+1) of the face nearest to the hit point
        label kBest = 0;
        scalar dBest = GREAT;
        forAll(f, k)
        {
            const triPointRef tri(c, gPoints[f[k]], gPoints[f.nextLabel(k)]);
            const scalar dk = magSqr(tri.nearestPoint(h).rawPoint() - h);
            if (dk < dBest)
            {
                dBest = dk;
                kBest = k;
            }
        }
        const FixedList<scalar, 3> lambda = clampedBarycentric
        (
            c, gPoints[f[kBest]], gPoints[f.nextLabel(kBest)], h
        );

        // Face centre taken as the mean of the face points
        start.append(sPoint.size());
        moved.append(pointi);
        dist.append(mag(h - x));
        forAll(f, k)
        {
            scalar wk = lambda[0]/f.size();
            if (k == kBest)
            {
                wk += lambda[1];
            }
            if (k == f.fcIndex(kBest))
            {
                wk += lambda[2];
            }
            sPoint.append(f[k]);
            sWeight.append(wk);
        }
    }
    start.append(sPoint.size());

    movedPoints_.transfer(moved);
    stencilStart_.transfer(start);
    stencilPoint_.transfer(sPoint);
    stencilWeight_.transfer(sWeight);

    // Decay with the distance from the interface
    scalar L = coeffDict().lookupOrDefault<scalar>("decayDistance", -1);
    if (L <= 0)
    {
        L = returnReduce(dist.size() ? max(dist) : 0.0, maxOp<scalar>());
    }
    L = max(L, SMALL);
    const word decayType
    (
        coeffDict().lookupOrDefault<word>("decay", "linear")
    );
    if (decayType != "linear" && decayType != "cubic")
    {
        FatalIOErrorInFunction(coeffDict())
            << "decay '" << decayType << "' unknown; use 'linear' or 'cubic'."
            << exit(FatalIOError);
    }
    decay_.setSize(dist.size());
    forAll(dist, i)
    {
        const scalar s = min(dist[i]/L, 1.0);
        decay_[i] = (decayType == "linear") ? 1 - s : sqr(1 - s)*(1 + 2*s);
    }

    Info<< type() << ": " << nGlobal_ << " interface points on patches "
        << patchNames << ", " << returnReduce(movedPoints_.size(), sumOp<label>())
        << " points interpolated, decay " << decayType << " over " << L
        << " m" << endl;
}


Foam::tmp<Foam::vectorField>
Foam::tqInterpolatedDisplacementMotionSolver::gatherInterfaceDisplacement()
const
{
    vectorField local(pointDisplacement_.primitiveField(), interfacePoints_);

    if (!Pstream::parRun())
    {
        return tmp<vectorField>(new vectorField(std::move(local)));
    }

    List<vectorField> procValues(Pstream::nProcs());
    procValues[Pstream::myProcNo()].transfer(local);
    Pstream::gatherList(procValues);
    Pstream::scatterList(procValues);
    return tmp<vectorField>
    (
        new vectorField
        (
            ListListOps::combine<vectorField>
            (
                procValues, accessOp<vectorField>()
            )
        )
    );
}


void Foam::tqInterpolatedDisplacementMotionSolver::subVolumes
(
    const pointField& points,
    scalarField& own,
    scalarField& nei,
    scalarField& vol
) const
{
    const polyMesh& mesh = this->mesh();
    const faceList& faces = mesh.faces();
    const labelList& owner = mesh.faceOwner();
    const labelList& neighbour = mesh.faceNeighbour();

    vectorField fc(faces.size());
    vectorField Sf(faces.size());
    forAll(faces, facei)
    {
        fc[facei] = faces[facei].centre(points);
        Sf[facei] = faces[facei].areaNormal(points);
    }

    // Apex of the cell's pyramids: the mean of its face centres (inside any
    // convex cell; the same construction for the reference and new points)
    vectorField cc(mesh.nCells(), Zero);
    labelList nFaces(mesh.nCells(), 0);
    forAll(owner, facei)
    {
        cc[owner[facei]] += fc[facei];
        ++nFaces[owner[facei]];
    }
    forAll(neighbour, facei)
    {
        cc[neighbour[facei]] += fc[facei];
        ++nFaces[neighbour[facei]];
    }
    forAll(cc, celli)
    {
        cc[celli] /= max(nFaces[celli], 1);
    }

    own.setSize(faces.size());
    nei.setSize(neighbour.size());
    vol.setSize(mesh.nCells());
    vol = 0;
    forAll(owner, facei)
    {
        own[facei] = (Sf[facei] & (fc[facei] - cc[owner[facei]]))/3;
        vol[owner[facei]] += own[facei];
    }
    forAll(neighbour, facei)
    {
        nei[facei] = (Sf[facei] & (cc[neighbour[facei]] - fc[facei]))/3;
        vol[neighbour[facei]] += nei[facei];
    }
}


void Foam::tqInterpolatedDisplacementMotionSolver::checkVolumes
(
    const pointField& newPoints
) const
{
    if (minVolumeRatio_ <= 0)
    {
        return;
    }
    scalarField own, nei, vol;
    subVolumes(newPoints, own, nei, vol);

    // Smallest sub-volume ratio of each cell; a non-finite value counts as
    // -GREAT (a displacement that is not a number)
    const labelList& owner = mesh().faceOwner();
    const labelList& neighbour = mesh().faceNeighbour();
    scalarField cellRatio(mesh().nCells(), GREAT);
    auto account = [&](const label celli, const scalar v, const scalar v0)
    {
        if (!(v0 > 0))
        {
            return;  // a degenerate reference pyramid: nothing to compare
        }
        const scalar r = std::isfinite(v) ? v/v0 : -GREAT;
        cellRatio[celli] = min(cellRatio[celli], r);
    };
    forAll(owner, facei)
    {
        account(owner[facei], own[facei], pyr0Own_[facei]);
    }
    forAll(neighbour, facei)
    {
        account(neighbour[facei], nei[facei], pyr0Nei_[facei]);
    }

    label worst = -1;
    label nBelow = 0;
    forAll(cellRatio, celli)
    {
        if (cellRatio[celli] < minVolumeRatio_)
        {
            ++nBelow;
        }
        if (worst < 0 || cellRatio[celli] < cellRatio[worst])
        {
            worst = celli;
        }
    }
    const scalar localMin = worst >= 0 ? cellRatio[worst] : GREAT;
    const scalar globalMin = returnReduce(localMin, minOp<scalar>());
    if (globalMin >= minVolumeRatio_)
    {
        return;
    }
    reduce(nBelow, sumOp<label>());

    // Details of the worst cell, from the rank that has it:
    // (ratio, cell, V/V0, x, y, z, rank)
    FixedList<scalar, 7> info(scalar(0));
    info[0] = GREAT;
    if (worst >= 0 && localMin == globalMin)
    {
        const point c = mesh().cellCentres()[worst];
        info[0] = localMin;
        info[1] = worst;
        info[2] = vol0_[worst] > 0 ? vol[worst]/vol0_[worst] : 0;
        info[3] = c.x();
        info[4] = c.y();
        info[5] = c.z();
        info[6] = Pstream::myProcNo();
    }
    List<FixedList<scalar, 7>> all(Pstream::nProcs());
    all[Pstream::myProcNo()] = info;
    Pstream::gatherList(all);
    Pstream::scatterList(all);
    for (const FixedList<scalar, 7>& a : all)
    {
        if (a[0] < info[0])
        {
            info = a;
        }
    }

    // The largest wall displacement of the step
    scalar uWall = 0;
    for (const label pointi : interfacePoints_)
    {
        uWall = max(uWall, mag(pointDisplacement_.primitiveField()[pointi]));
    }
    reduce(uWall, maxOp<scalar>());

    const bool finite = globalMin > -GREAT;
    const string ratioText
    (
        finite
      ? Foam::name(info[0])
      : string("not finite (the displacement is not a number)")
    );
    const string rankText
    (
        Pstream::parRun() ? " of rank " + Foam::name(label(info[6])) : ""
    );
    FatalErrorInFunction
        << type() << ": the mesh motion at t = " << mesh().time().value()
        << " s would shrink " << nBelow << " cell(s) below minVolumeRatio "
        << minVolumeRatio_ << " of their reference volume: smallest"
        << " sub-volume ratio " << ratioText.c_str()
        << " in cell " << label(info[1]) << rankText.c_str()
        << " (centre (" << info[3] << ' ' << info[4] << ' ' << info[5]
        << ") in the current mesh, volume ratio V/V0 = " << info[2] << ")."
        << " The mesh was not moved; a ratio of 0 is a degenerate cell, below"
        << " 0 an inverted one." << nl
        << "Likely cause: the wall displacement (up to " << uWall << " m) is"
        << " no longer small against the cells next to the wall: the motion"
        << " is interpolated, not solved, and large or uneven wall motion"
        << " folds the cells (or the solid has diverged)." << nl
        << "Fix: check that the wall motion is physical (an earthquake moves"
        << " the lining by centimetres relative to the rock around it), use a"
        << " smaller wall motion, use 'interfaceMotion transpiration;' on a"
        << " static mesh for small motion, or use a finer/better mesh near the"
        << " wall (or decay cubic / a larger decayDistance to spread the"
        << " motion).  minVolumeRatio in tqInterpolatedDisplacementCoeffs sets"
        << " the limit (0: off)." << exit(FatalError);
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tqInterpolatedDisplacementMotionSolver::
tqInterpolatedDisplacementMotionSolver
(
    const polyMesh& mesh,
    const IOdictionary& dict
)
:
    displacementMotionSolver(mesh, dict, typeName),
    globalOffset_(0),
    nGlobal_(0),
    minVolumeRatio_(coeffDict().lookupOrDefault<scalar>("minVolumeRatio", 0.1))
{
    if (!(minVolumeRatio_ >= 0 && minVolumeRatio_ < 1))
    {
        FatalIOErrorInFunction(coeffDict())
            << "minVolumeRatio " << minVolumeRatio_ << " must be in [0, 1)"
            << " (the smallest accepted ratio of a cell's sub-volume to its"
            << " reference; default 0.1, 0 turns the check off)."
            << exit(FatalIOError);
    }
    calcWeights();
    subVolumes(points0(), pyr0Own_, pyr0Nei_, vol0_);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::tmp<Foam::pointField>
Foam::tqInterpolatedDisplacementMotionSolver::curPoints() const
{
    tmp<pointField> tcurPoints
    (
        points0() + pointDisplacement_.primitiveField()
    );
    twoDCorrectPoints(tcurPoints.ref());
    checkVolumes(tcurPoints());
    return tcurPoints;
}


void Foam::tqInterpolatedDisplacementMotionSolver::solve()
{
    // Interface values from the boundary conditions into the point field
    pointDisplacement_.boundaryFieldRef().updateCoeffs();
    pointDisplacement_.correctBoundaryConditions();

    const tmp<vectorField> tuI = gatherInterfaceDisplacement();
    const vectorField& uI = tuI();
    const vector uMean = sum(globalAreaWeight_*uI);

    vectorField& pd = pointDisplacement_.primitiveFieldRef();
    forAll(movedPoints_, i)
    {
        vector u = Zero;
        for (label k = stencilStart_[i]; k < stencilStart_[i + 1]; ++k)
        {
            u += stencilWeight_[k]*uI[stencilPoint_[k]];
        }
        pd[movedPoints_[i]] = uMean + decay_[i]*(u - uMean);
    }

    // Conditions of the other patches (e.g. slip on a plane end)
    pointDisplacement_.correctBoundaryConditions();
}


void Foam::tqInterpolatedDisplacementMotionSolver::updateMesh
(
    const mapPolyMesh&
)
{
    FatalErrorInFunction
        << "Topology changes are not supported by " << typeName
        << exit(FatalError);
}


// ************************************************************************* //
