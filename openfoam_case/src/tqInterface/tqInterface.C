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

#include "tqInterface.H"
#include "interfaceTraction.H"
#include "wallCellGradient.H"
#include "volFields.H"
#include "surfaceFields.H"
#include "pointFields.H"
#include "fixedValuePointPatchFields.H"
#include "tqInterfaceVelocityFvPatchVectorField.H"
#include "fvcGrad.H"
#include "fvcDdt.H"
#include "IOdictionary.H"
#include "OFstream.H"
#include "OSspecific.H"
#include "addToRunTimeSelectionTable.H"
#include "tq/coupler/crc32.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <malloc.h>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <iterator>
#include <sstream>
#include <unistd.h>
#include <vector>

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace functionObjects
{
    defineTypeNameAndDebug(tqInterface, 0);
    addToRunTimeSelectionTable(functionObject, tqInterface, dictionary);
}
}

const Foam::Enum
<
    Foam::functionObjects::tqInterface::wallPressureType
>
Foam::functionObjects::tqInterface::wallPressureTypeNames_
({
    { wallPressureType::patchValue, "patchValue" },
    { wallPressureType::extrapolated, "extrapolated" },
});

const Foam::Enum
<
    Foam::functionObjects::tqInterface::interfaceMotionType
>
Foam::functionObjects::tqInterface::interfaceMotionTypeNames_
({
    { interfaceMotionType::meshMotion, "meshMotion" },
    { interfaceMotionType::transpiration, "transpiration" },
});


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

Foam::scalar Foam::functionObjects::tqInterface::nu() const
{
    if (nu_ > 0)
    {
        return nu_;
    }
    if (foundObject<IOdictionary>("transportProperties"))
    {
        const IOdictionary& tp =
            lookupObject<IOdictionary>("transportProperties");
        return dimensionedScalar("nu", dimViscosity, tp).value();
    }
    FatalErrorInFunction
        << "No viscosity: give 'nu' [m^2/s] in the " << name()
        << " dictionary or constant/transportProperties." << exit(FatalError);
    return 0;
}


void Foam::functionObjects::tqInterface::calcLoads()
{
    const fvPatch& fvp = mesh_.boundary()[patchi_];
    const polyPatch& pp = fvp.patch();
    const faceList& lf = pp.localFaces();
    const volScalarField& p = lookupObject<volScalarField>(pName_);
    const volVectorField& U = lookupObject<volVectorField>(UName_);

    // Transpiration with the geometric correction: the loads act on the
    // displaced interface, not on the (fixed) mesh faces
    const bool displaced =
        interfaceMotion_ == interfaceMotionType::transpiration
     && geometricCorrection_;

    pointField xLoaded(pp.localPoints());
    vectorField Sf(fvp.Sf());
    vectorField faceShift;
    if (displaced)
    {
        xLoaded += displacement_;
        forAll(lf, facei)
        {
            Sf[facei] = lf[facei].areaNormal(xLoaded);
        }
        faceShift = faceAverage(displacement_);
    }

    // Face density [kg/m^3] and the factor taking p to Pa
    scalarField rhoF(fvp.size(), rhoInf_);
    scalar pToPa = rhoInf_;
    if (rhoName_ != "rhoInf")
    {
        rhoF = lookupObject<volScalarField>(rhoName_).boundaryField()[patchi_];
        pToPa = 1;
    }

    // Wall pressure, in p's units
    pCell_ = p.boundaryField()[patchi_].patchInternalField();
    scalarField pW;
    if (wallPressure_ == wallPressureType::patchValue && !displaced)
    {
        pW = p.boundaryField()[patchi_];
    }
    else
    {
        const vectorField nf(fvp.nf());
        const vectorField d(fvp.Cf() - fvp.Cn());
        const scalarField dn(nf & d);

        // Wall-normal pressure gradient, in p's units per m
        scalarField dpdn;
        if (wallPressure_ == wallPressureType::extrapolated)
        {
            // Wall acceleration: ddt(U) on the patch, by U's ddt scheme;
            // normal momentum at a no-slip wall: dp/dn = -a_w.n (kinematic
            // p)
            // (patch only for Euler and backward, else the whole field)
            bool backward = false;
            if (tq::simpleDdtScheme(mesh_, "ddt(" + UName_ + ')', backward))
            {
                dpdn = -(tq::patchDdt(U, patchi_, backward) & nf);
            }
            else
            {
                const tmp<volVectorField> tddtU(fvc::ddt(U));
                dpdn = -(tddtU().boundaryField()[patchi_] & nf);
            }
            if (rhoName_ != "rhoInf")
            {
                dpdn *= rhoF;
            }
        }
        else
        {
            dpdn = p.boundaryField()[patchi_].snGrad();
        }

        // Gradient of the wall cells (patch only for 'Gauss linear')
        vectorField gradPc;
        if (tq::isGaussLinear(mesh_, "grad(" + pName_ + ')'))
        {
            gradPc = tq::wallCellGaussGrad(p, patchi_);
        }
        else
        {
            const tmp<volVectorField> tgradP(fvc::grad(p));
            gradPc = tgradP().boundaryField()[patchi_].patchInternalField();
        }

        if (wallPressure_ == wallPressureType::extrapolated)
        {
            pW = pCell_ + dn*dpdn + ((d - nf*dn) & gradPc);
        }
        else
        {
            pW = p.boundaryField()[patchi_];
        }

        if (displaced)
        {
            // Pressure at the displaced face centre, to first order:
            // p_w + u_f . grad(p)_w, normal part from dp/dn, tangential part
            // from the wall cell's gradient
            const scalarField un(faceShift & nf);
            pW += un*dpdn + ((faceShift - nf*un) & gradPc);
        }
    }
    pWall_ = pToPa*(pW - pRef_);
    pCell_ = pToPa*(pCell_ - pRef_);
    const scalarField magSf(mag(Sf));
    const scalar area = returnReduce(sum(magSf), sumOp<scalar>());
    pMean_ =
        returnReduce(sum(pWall_*magSf), sumOp<scalar>())
       /max(area, VSMALL);
    if (subtractMeanPressure_)
    {
        // The uniform part is the solid's volume law: only the remainder
        // (the water's inertia) is sent
        pWall_ -= pMean_;
        pCell_ -= pMean_;
    }

    // Pressure part: p_w S_f (S_f points out of the water, into the lining)
    faceForceP_ = pWall_*Sf;

    // Viscous part: S_f . devRhoReff, devRhoReff = -mu_eff dev(twoSymm(gradU))
    {
        scalarField nuEff(fvp.size(), nu());
        const volScalarField* nutPtr = findObject<volScalarField>("nut");
        if (nutPtr)
        {
            nuEff += nutPtr->boundaryField()[patchi_];
        }
        // Wall value of grad(U) (patch only for 'Gauss linear')
        tensorField gradUb;
        if (tq::isGaussLinear(mesh_, "grad(" + UName_ + ')'))
        {
            gradUb = tq::wallGradCorrected
            (
                U, patchi_, tq::wallCellGaussGrad(U, patchi_)()
            );
        }
        else
        {
            const tmp<volTensorField> tgradU(fvc::grad(U));
            gradUb = tgradU().boundaryField()[patchi_];
        }
        faceForceV_ = Sf & (-(rhoF*nuEff)*dev(twoSymm(gradUb)));
    }
    faceForce_ = faceForceP_ + faceForceV_;

    // Point forces (conservative map), on the loaded geometry
    pointForce_ =
        tq::distributeMedianDual(lf, xLoaded, pp.nPoints(), faceForce_);

    totalP_ = returnReduce(sum(faceForceP_), sumOp<vector>());
    totalV_ = returnReduce(sum(faceForceV_), sumOp<vector>());
    totalPoint_ = returnReduce(sum(pointForce_), sumOp<vector>());

    totalHs_ = Zero;
    if (hydrostatic_)
    {
        const scalar magG = mag(g_);
        const vector up(-g_/magG);
        vectorField Cf(fvp.Cf());
        if (displaced)
        {
            Cf += faceShift;
        }
        const scalarField pHs(rhoF*magG*(freeSurfaceLevel_ - (up & Cf)));
        totalHs_ = returnReduce(sum(pHs*Sf), sumOp<vector>());
    }
}


Foam::tmp<Foam::vectorField>
Foam::functionObjects::tqInterface::faceAverage
(
    const vectorField& pointValues
) const
{
    const faceList& lf = mesh_.boundaryMesh()[patchi_].localFaces();
    tmp<vectorField> tfv(new vectorField(lf.size(), Zero));
    vectorField& fv = tfv.ref();
    forAll(lf, facei)
    {
        for (const label pointi : lf[facei])
        {
            fv[facei] += pointValues[pointi];
        }
        fv[facei] /= lf[facei].size();
    }
    return tfv;
}


void Foam::functionObjects::tqInterface::applyMotion()
{
    if (interfaceMotion_ == interfaceMotionType::transpiration)
    {
        const volVectorField& U = lookupObject<volVectorField>(UName_);
        vectorField Uw(faceAverage(velocity_));

        if (geometricCorrection_)
        {
            // Flux through each fixed face = the volume the displaced face
            // sweeps: v.S_f(x0 + u) instead of v.S_f(x0).  Keeps the
            // second-order volume change of the wall (an ovaling wall
            // encloses less volume), which an open pipe turns into a
            // uniform pressure of order rho L^2/(12 V) d2V/dt2.
            const polyPatch& pp = mesh_.boundaryMesh()[patchi_];
            const faceList& lf = pp.localFaces();
            const vectorField& S0 = pp.faceAreas();
            const pointField xd(points0_ + displacement_);
            forAll(lf, facei)
            {
                const vector Sd(lf[facei].areaNormal(xd));
                const scalar magS0 = mag(S0[facei]);
                Uw[facei] +=
                    S0[facei]*((Uw[facei] & (Sd - S0[facei]))/sqr(magS0));
            }

            // Closed incompressible water cannot change volume (the check of
            // checkVolumeChange has let the first-order flux through): take
            // the net flux off uniformly, or adjustPhi finds a one-signed
            // wall flux near a velocity reversal and stops
            const volScalarField& p = lookupObject<volScalarField>(pName_);
            if (rhoName_ == "rhoInf" && p.needReference())
            {
                const scalar net =
                    returnReduce(sum(Uw & S0), sumOp<scalar>());
                const scalar area =
                    returnReduce(sum(mag(S0)), sumOp<scalar>());
                Uw -= (net/max(area, VSMALL))*S0/mag(S0);
            }
        }

        // Only the condition's pending wall velocity changes, not the
        // field's values (the old-time level keeps this step's velocity)
        fvPatchVectorField& Up =
            const_cast<fvPatchVectorField&>(U.boundaryField()[patchi_]);
        refCast<tqInterfaceVelocityFvPatchVectorField>(Up).setWallVelocity
        (
            Uw
        );
        return;
    }

    pointVectorField* pDPtr =
        mesh_.getObjectPtr<pointVectorField>("pointDisplacement");
    pointPatchVectorField& ppf = pDPtr->boundaryFieldRef()[patchi_];
    refCast<fixedValuePointPatchVectorField>(ppf) == displacement_;
}


void Foam::functionObjects::tqInterface::checkMotionSetup() const
{
    const pointVectorField* pDPtr =
        mesh_.findObject<pointVectorField>("pointDisplacement");

    if (interfaceMotion_ == interfaceMotionType::transpiration)
    {
        if (pDPtr)
        {
            FatalErrorInFunction
                << "interfaceMotion transpiration keeps the mesh fixed, but"
                << " the mesh has a motion solver (pointDisplacement)." << nl
                << "Fix: in constant/dynamicMeshDict set 'dynamicFvMesh"
                << " staticFvMesh;', or use interfaceMotion meshMotion."
                << exit(FatalError);
        }
        const volVectorField& U = lookupObject<volVectorField>(UName_);
        if (!isA<tqInterfaceVelocityFvPatchVectorField>(U.boundaryField()[patchi_]))
        {
            FatalErrorInFunction
                << UName_ << " on patch " << patchName_ << " is of type '"
                << U.boundaryField()[patchi_].type() << "'." << nl
                << "Fix: with interfaceMotion transpiration the interface"
                << " velocity must be 'tqInterfaceVelocity' (it receives the"
                << " wall velocity)." << exit(FatalError);
        }
        return;
    }

    if (rhoName_ != "rhoInf")
    {
        // v1912 rhoPimpleFoam (pEqn.H) makes phiHbyA relative to the mesh
        // motion before constrainPressure, which compares it with the
        // absolute wall flux rho S_f.U_b: the flux of a moving wall enters
        // twice (measured on a closed contracting pipe: p = 2.00 K dV/V).
        FatalErrorInFunction
            << "The compressible water (rho " << rhoName_ << ") cannot be"
            << " coupled with interfaceMotion meshMotion in OpenFOAM v1912:"
            << " rhoPimpleFoam makes the flux relative to the mesh motion"
            << " before constrainPressure, so the flux of the moving wall is"
            << " counted twice (a closed pipe compressed by dV gets"
            << " p = -2 K dV/V)." << nl
            << "Fix: use 'interfaceMotion transpiration;' (static mesh,"
            << " dynamicFvMesh staticFvMesh), which is exact to first order"
            << " in the wall displacement and keeps the volume change of the"
            << " displaced wall." << exit(FatalError);
    }

    if (!pDPtr)
    {
        FatalErrorInFunction
            << "The exchange moves the interface, but the mesh has no"
            << " pointDisplacement field." << nl
            << "Fix: in constant/dynamicMeshDict use dynamicFvMesh"
            << " dynamicMotionSolverFvMesh with motionSolver"
            << " tqInterpolatedDisplacement (or another displacement-based"
            << " solver), and give 0/pointDisplacement; or use"
            << " interfaceMotion transpiration on a static mesh."
            << exit(FatalError);
    }

    const pointPatchVectorField& ppf = pDPtr->boundaryField()[patchi_];
    if (!isA<fixedValuePointPatchVectorField>(ppf))
    {
        FatalErrorInFunction
            << "pointDisplacement on patch " << patchName_ << " is of type '"
            << ppf.type() << "'." << nl
            << "Fix: make it 'fixedValue' (value uniform (0 0 0);) so that"
            << " the received interface displacement can be applied."
            << exit(FatalError);
    }
}


void Foam::functionObjects::tqInterface::receiveMotion()
{
    const scalar tNext = time().value() + time().deltaTValue();
    exchange_->readMotion(tNext, displacement_, velocity_);

    const label nPoints = points0_.size();
    if (displacement_.size() != nPoints || velocity_.size() != nPoints)
    {
        FatalErrorInFunction
            << "The exchange returned " << displacement_.size()
            << " displacements and " << velocity_.size() << " velocities for "
            << nPoints << " interface points of patch " << patchName_
            << exit(FatalError);
    }
    if (interfaceMotion_ == interfaceMotionType::transpiration)
    {
        checkTranspirationDisplacement();
    }
    checkVolumeChange();
    applyMotion();
}


void Foam::functionObjects::tqInterface::checkTranspirationDisplacement()
const
{
    // The transpiration interface keeps the faces fixed and puts the wall
    // motion back through first-order terms (flux of the displaced face,
    // p_w + u.grad p at the displaced centre): Taylor steps from the face
    // into its wall cell, whose pressure and gradient they use.  A wall
    // displaced beyond that cell would need values the terms ignore, and
    // the neglected second-order terms are no longer small: refuse the
    // motion rather than give wrong loads.
    const faceList& lf = mesh_.boundaryMesh()[patchi_].localFaces();
    scalar worst = -1;
    label worstFace = -1;
    scalar worstU = 0;
    bool finite = true;
    forAll(lf, facei)
    {
        scalar uMax = 0;
        for (const label pointi : lf[facei])
        {
            const scalar u = mag(displacement_[pointi]);
            if (!std::isfinite(u))
            {
                finite = false;
            }
            uMax = max(uMax, u);
        }
        const scalar ratio = uMax/max(wallCellThickness_[facei], VSMALL);
        if (!std::isfinite(uMax) || ratio > worst)
        {
            worst = std::isfinite(uMax) ? ratio : GREAT;
            worstFace = facei;
            worstU = uMax;
        }
    }
    const scalar globalWorst = returnReduce(worst, maxOp<scalar>());
    const bool globalFinite = returnReduce(finite, andOp<bool>());
    if (globalFinite && globalWorst <= transpirationLimit_)
    {
        return;
    }

    // Details of the worst face (from the rank that has it)
    FixedList<scalar, 6> info(scalar(0));
    if (worstFace >= 0 && worst == globalWorst)
    {
        // (z, face, |u|, h_w, x, y)
        const point& c = mesh_.boundary()[patchi_].Cf()[worstFace];
        info[0] = c.z();
        info[1] = worstFace;
        info[2] = worstU;
        info[3] = wallCellThickness_[worstFace];
        info[4] = c.x();
        info[5] = c.y();
    }
    {
        List<FixedList<scalar, 6>> all(Pstream::nProcs());
        all[Pstream::myProcNo()] = info;
        Pstream::gatherList(all);
        Pstream::scatterList(all);
        for (const FixedList<scalar, 6>& a : all)
        {
            if (a[2] != 0 || a[3] != 0)
            {
                info = a;
                break;
            }
        }
    }
    const scalar tNext = time().value() + time().deltaTValue();
    FatalErrorInFunction
        << "interfaceMotion transpiration: the received wall displacement"
        << " at t = " << tNext << " s is too large for the transpiration"
        << " interface's linearisation: |u| = " << info[2] << " m at face "
        << label(info[1]) << " of patch " << patchName_ << " (centre ("
        << info[4] << ' ' << info[5] << ' ' << info[0] << ")), whose wall"
        << " cell is h_w = " << info[3] << " m thick: |u|/h_w = "
        << (globalFinite ? globalWorst : GREAT) << " > transpirationLimit "
        << transpirationLimit_
        << (globalFinite ? "" : " (the displacement is not finite)") << "."
        << nl
        << "Transpiration keeps the mesh fixed and moves the wall by"
        << " first-order terms from the face into its wall cell; a wall"
        << " displaced out of that cell would get wrong loads and fluxes."
        << nl
        << "Likely cause: a wall motion far larger than an earthquake's"
        << " (centimetres), e.g. absolute instead of relative displacements,"
        << " or a diverging solid." << nl
        << "Fix: use 'interfaceMotion meshMotion;' with the"
        << " tqInterpolatedDisplacement motion solver for large motion, or a"
        << " mesh with thicker wall cells, or (if the motion is right and the"
        << " accuracy acceptable) raise transpirationLimit in the " << name()
        << " dictionary." << exit(FatalError);
}


void Foam::functionObjects::tqInterface::checkVolumeChange() const
{
    // Incompressible water in a closed domain (no fixed-value pressure
    // anywhere) cannot change volume: refuse a wall motion that asks for it.
    if (rhoName_ != "rhoInf")
    {
        return;
    }
    const volScalarField& p = lookupObject<volScalarField>(pName_);
    if (!p.needReference())
    {
        return;
    }

    const polyPatch& pp = mesh_.boundaryMesh()[patchi_];
    const faceList& lf = pp.localFaces();
    const vectorField& Sf = pp.faceAreas();
    scalar dVdt = 0;
    scalar scale = 0;
    forAll(lf, facei)
    {
        vector vf = Zero;
        for (const label pointi : lf[facei])
        {
            vf += velocity_[pointi];
        }
        vf /= lf[facei].size();
        dVdt += vf & Sf[facei];
        scale += mag(vf)*mag(Sf[facei]);
    }
    reduce(dVdt, sumOp<scalar>());
    reduce(scale, sumOp<scalar>());

    if (mag(dVdt) > volumeChangeTol_*max(scale, VSMALL))
    {
        FatalErrorInFunction
            << "The received wall motion changes the volume of the water"
            << " (dV/dt = " << dVdt << " m^3/s through patch " << patchName_
            << ", " << mag(dVdt)/max(scale, VSMALL) << " of the wall flux"
            << " magnitude) but the water is incompressible and the domain"
            << " is closed (no fixed-value pressure boundary): the problem"
            << " has no solution." << nl
            << "Fix: open the axial ends (p fixedValue on end_ymin/end_ymax,"
            << " as tunnelquake.water_case writes open ends), or use the weakly"
            << " compressible water model (rhoPimpleFoam), or set volumeChangeTolerance"
            << " in the " << name() << " dictionary if this is a round-off"
            << " effect." << exit(FatalError);
    }
}


void Foam::functionObjects::tqInterface::writeRow
(
    const scalar t,
    const bool accepted
)
{
    const bool print = logInterval_ <= 0 || (accepted && logDue(t));
    if (print)
    {
        Log << type() << " " << name() << ": t = " << t
            << (accepted ? "" : " (rolled back)") << nl
            << "    force on lining [N] " << (totalP_ + totalV_)
            << " (pressure " << totalP_ << ", viscous " << totalV_ << ")"
            << nl;
        if (hydrostatic_)
        {
            Log << "    hydrostatic resultant [N] " << totalHs_ << nl;
        }
    }
    if (print && accepted && logInterval_ > 0)
    {
        // The next multiple of the interval after t
        const scalar dt = time().deltaTValue();
        nextLogTime_ =
            (std::floor((t + 0.5*dt)/logInterval_) + 1)*logInterval_;
    }

    if (!filePtr_.valid())
    {
        return;
    }
    OFstream& os = filePtr_();
    const vector F(totalP_ + totalV_);

    // The row's text is what 'os << value' writes to the file (scientific,
    // precision 15: %.15e; writeFile::initStream), made by std::to_chars:
    // the stream's locale-aware conversion cost more than the rest of
    // the row's work
    // 19 values of at most 23 characters (-d.ddddddddddddddde-308), spaces
    char row[19*24];
    char* const end = row + sizeof(row);
    char* c = row;
    const auto put = [&c, end](const scalar v, const bool space)
    {
        if (space)
        {
            *c++ = ' ';
        }
        c = std::to_chars(c, end, v, std::chars_format::scientific, 15).ptr;
    };
    put(t, false);
    *c++ = ' ';
    *c++ = accepted ? '1' : '0';
    for (const vector& v : {F, totalP_, totalV_, totalHs_, totalPoint_})
    {
        put(v.x(), true);
        put(v.y(), true);
        put(v.z(), true);
    }
    put(pMean_, true);
    *c++ = ' ';
    c = std::to_chars(c, end, nRollbacks_).ptr;
    *c++ = '\n';
    // One write a printed pass, not one a pass (the stream's buffer holds
    // the rows in between; the file is complete when the run ends)
    os.stdStream().write(row, std::streamsize(c - row));
    if (print)
    {
        os.flush();
    }
}


bool Foam::functionObjects::tqInterface::logDue(const scalar t) const
{
    const scalar dt = time().deltaTValue();
    return
        logInterval_ <= 0
     || t >= nextLogTime_ - 0.5*dt
     || t >= endTime_ - 0.5*dt;
}


void Foam::functionObjects::tqInterface::setSolverOutput()
{
    if (!quietSolver_ || logInterval_ <= 0)
    {
        return;
    }
    const scalar tNext = time().value() + time().deltaTValue();
    messageStream::level = logDue(tNext) ? infoLevel_ : 0;
}


void Foam::functionObjects::tqInterface::writeFields() const
{
    const fvPatch& fvp = mesh_.boundary()[patchi_];
    const polyPatch& pp = fvp.patch();

    const fileName dir(baseTimeDir());
    mkDir(dir);
    const word suffix
    (
        Pstream::parRun() ? "_proc" + Foam::name(Pstream::myProcNo()) : ""
    );

    {
        OFstream os(dir/"faces" + suffix + ".dat");
        os.precision(12);
        os  << "# x y z Sx Sy Sz pWall[Pa] pCell[Pa] fx fy fz [N]" << nl;
        const vectorField& Cf = fvp.Cf();
        const vectorField& Sf = fvp.Sf();
        forAll(Cf, facei)
        {
            os  << Cf[facei].x() << ' ' << Cf[facei].y() << ' '
                << Cf[facei].z() << ' ' << Sf[facei].x() << ' '
                << Sf[facei].y() << ' ' << Sf[facei].z() << ' '
                << pWall_[facei] << ' ' << pCell_[facei] << ' '
                << faceForce_[facei].x() << ' ' << faceForce_[facei].y()
                << ' ' << faceForce_[facei].z() << nl;
        }
    }
    {
        OFstream os(dir/"points" + suffix + ".dat");
        os.precision(12);
        os  << "# x0 y0 z0 x y z ux uy uz vx vy vz fx fy fz" << nl;
        // Current interface: the moved mesh, or (transpiration) the
        // reference points plus the received displacement
        pointField x(pp.localPoints());
        if (interfaceMotion_ == interfaceMotionType::transpiration)
        {
            x = points0_ + displacement_;
        }
        forAll(x, i)
        {
            for
            (
                const vector& v
              : {points0_[i], x[i], displacement_[i], velocity_[i],
                 pointForce_[i]}
            )
            {
                os  << v.x() << ' ' << v.y() << ' ' << v.z() << ' ';
            }
            os  << nl;
        }
    }
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::functionObjects::tqInterface::tqInterface
(
    const word& name,
    const Time& runTime,
    const dictionary& dict
)
:
    fvMeshFunctionObject(name, runTime, dict),
    writeFile(mesh_, name, typeName, dict),
    patchName_(),
    patchi_(-1),
    pName_("p"),
    UName_("U"),
    rhoName_("rhoInf"),
    rhoInf_(1),
    pRef_(0),
    volumeChangeTol_(1e-3),
    nu_(-1),
    wallPressure_(wallPressureType::extrapolated),
    interfaceMotion_(interfaceMotionType::meshMotion),
    geometricCorrection_(true),
    transpirationLimit_(1),
    wallCellThickness_(),
    hydrostatic_(false),
    g_(Zero),
    freeSurfaceLevel_(0),
    exchange_(),
    checkpoint_(mesh_),
    endTime_(runTime.endTime().value()),
    totalP_(Zero),
    totalV_(Zero),
    totalHs_(Zero),
    totalPoint_(Zero),
    pMean_(0),
    subtractMeanPressure_(false),
    nRollbacks_(0),
    rewriteTime_(-1),
    filePtr_(),
    logInterval_(0),
    quietSolver_(false),
    nextLogTime_(runTime.value()),
    infoLevel_(messageStream::level),
    restartDir_(),
    restartWindows_(0),
    lastRestartWindow_(-1),
    prevRestartWindow_(-1)
{
    // A wrong coupling set-up must end the run: while constructing function
    // objects OpenFOAM turns FatalError into a warning and would go on
    // uncoupled.
    const bool throwing = FatalError.dontThrowExceptions();
    const bool throwingIO = FatalIOError.dontThrowExceptions();

    read(dict);

    if (dict.lookupOrDefault<bool>("heapTuning", true))
    {
        // OpenFOAM allocates and frees field temporaries of 0.1-1 MB many
        // times per step; glibc serves blocks above its mmap threshold with
        // mmap/munmap, so every temporary costs fresh page faults (measured:
        // 15 % of a water step on the paper mesh).  Keep freed memory in the
        // heap instead (process-wide; the solver's memory use is steady).
        mallopt(M_MMAP_THRESHOLD, 512*1024*1024);
        mallopt(M_TRIM_THRESHOLD, 1024*1024*1024);
    }

    // The wall acceleration of the first step is ddt(U) on the patch against
    // the initial state: create U's old-time level now, before the first
    // mesh motion updates the wall velocity (OpenFOAM would otherwise create
    // it lazily from the already updated boundary values).
    if (wallPressure_ == wallPressureType::extrapolated)
    {
        lookupObject<volVectorField>(UName_).oldTime();
    }

    const polyPatch& pp = mesh_.boundaryMesh()[patchi_];
    points0_ = pp.localPoints();
    {
        const fvPatch& fvp = mesh_.boundary()[patchi_];
        wallCellThickness_ =
            2*mag(fvp.nf() & (fvp.Cf() - fvp.Cn()));
    }
    displacement_.setSize(pp.nPoints(), Zero);
    velocity_.setSize(pp.nPoints(), Zero);

    // Interface description for the partner
    const faceList& lf = pp.localFaces();
    const scalarField pointArea
    (
        tq::pointAreas
        (
            lf,
            tq::medianDualWeights(lf, points0_),
            pp.nPoints(),
            mag(pp.faceAreas())
        )
    );

    if (dict.found("exchange"))
    {
        exchange_ = tq::interfaceExchange::New(runTime, dict.subDict("exchange"));
    }
    else
    {
        exchange_.reset(new tq::noneExchange(runTime, dictionary()));
    }
    restartDir_ = dict.lookupOrDefault<fileName>("restartDir", fileName::null);
    restartDir_.expand();
    restartWindows_ = dict.lookupOrDefault<label>("restartWindows", 0);
    inputFingerprint_ =
        dict.lookupOrDefault<string>("inputFingerprint", string::null);
    fileName restartFrom
    (
        dict.lookupOrDefault<fileName>("restartFrom", fileName::null)
    );
    restartFrom.expand();
    std::string resumedRows;
    bool resumed = false;
    if (restartFrom.empty())
    {
        exchange_->initialize(pp, points0_, pointArea);
    }
    else
    {
        resumedRows = readRestart(restartFrom, pp, pointArea);
        resumed = true;
    }

    if (exchange_->isCouplingOngoing())
    {
        checkMotionSetup();

        // The coupling owns the end of the run (see class description)
        endTime_ = runTime.endTime().value();
        const_cast<Time&>(runTime).setEndTime
        (
            endTime_ + 10*runTime.deltaTValue()
        );

        if (!resumed && exchange_->requiresWritingCheckpoint())
        {
            checkpoint_.store();
        }
        receiveMotion();
    }

    FatalError.throwExceptions(throwing);
    FatalIOError.throwExceptions(throwingIO);

    filePtr_ = createFile("interface");
    if (filePtr_.valid() && resumed)
    {
        // interface.dat as it was at the checkpoint, rows go on from there
        filePtr_().stdStream().write
        (
            resumedRows.data(),
            std::streamsize(resumedRows.size())
        );
        filePtr_().precision(15);
    }
    else if (filePtr_.valid())
    {
        OFstream& os = filePtr_();
        os.precision(15);
        writeHeader(os, "tqInterface: water loads on patch " + patchName_);
        writeHeader
        (
            os,
            "t accepted Fx Fy Fz Fpx Fpy Fpz Fvx Fvy Fvz Fhsx Fhsy Fhsz"
            " sumPointFx sumPointFy sumPointFz pMean nRollbacks"
        );
        writeHeader
        (
            os,
            "units: s - N N N N N N N N N N N N N N N Pa -"
        );
    }
}


// * * * * * * * * * * * * * * * * Destructor  * * * * * * * * * * * * * * * //

Foam::functionObjects::tqInterface::~tqInterface()
{
    messageStream::level = infoLevel_;
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

bool Foam::functionObjects::tqInterface::read(const dictionary& dict)
{
    fvMeshFunctionObject::read(dict);
    writeFile::read(dict);

    patchName_ = dict.get<word>("patch");
    patchi_ = mesh_.boundaryMesh().findPatchID(patchName_);
    if (patchi_ < 0)
    {
        FatalIOErrorInFunction(dict)
            << "Unknown patch '" << patchName_ << "' (entry 'patch')." << nl
            << "Patches of the mesh: " << mesh_.boundaryMesh().names()
            << exit(FatalIOError);
    }

    pName_ = dict.lookupOrDefault<word>("p", "p");
    UName_ = dict.lookupOrDefault<word>("U", "U");
    rhoName_ = dict.lookupOrDefault<word>("rho", "rhoInf");
    if (rhoName_ == "rhoInf")
    {
        rhoInf_ = dict.get<scalar>("rhoInf");
        if (rhoInf_ <= 0)
        {
            FatalIOErrorInFunction(dict)
                << "rhoInf " << rhoInf_ << " must be positive (water: 1000)."
                << exit(FatalIOError);
        }
    }
    pRef_ = dict.lookupOrDefault<scalar>("pRef", 0);
    volumeChangeTol_ =
        dict.lookupOrDefault<scalar>("volumeChangeTolerance", 1e-3);
    nu_ = dict.lookupOrDefault<scalar>("nu", -1);
    wallPressure_ = wallPressureTypeNames_.lookupOrDefault
    (
        "wallPressure",
        dict,
        wallPressureType::extrapolated
    );
    interfaceMotion_ = interfaceMotionTypeNames_.lookupOrDefault
    (
        "interfaceMotion",
        dict,
        interfaceMotionType::meshMotion
    );
    geometricCorrection_ =
        dict.lookupOrDefault<bool>("geometricCorrection", true);
    transpirationLimit_ =
        dict.lookupOrDefault<scalar>("transpirationLimit", 1);
    if (!(transpirationLimit_ > 0))
    {
        FatalIOErrorInFunction(dict)
            << "transpirationLimit " << transpirationLimit_ << " must be"
            << " positive (a fraction of the wall-cell thickness; default"
            << " 1)." << exit(FatalIOError);
    }

    logInterval_ = dict.lookupOrDefault<scalar>("logInterval", 0);
    quietSolver_ = dict.lookupOrDefault<bool>("quietSolver", false);
    subtractMeanPressure_ =
        dict.lookupOrDefault<bool>("subtractMeanPressure", false);
    if (quietSolver_ && !(logInterval_ > 0))
    {
        FatalIOErrorInFunction(dict)
            << "quietSolver yes needs a positive logInterval (s of"
            << " simulated time between printed passes), got logInterval "
            << logInterval_ << "." << nl
            << "Fix: give e.g. 'logInterval 0.01;', or 'quietSolver no;'."
            << exit(FatalIOError);
    }

    hydrostatic_ = dict.found("hydrostatic");
    if (hydrostatic_)
    {
        const dictionary& hd = dict.subDict("hydrostatic");
        g_ = hd.get<vector>("g");
        freeSurfaceLevel_ = hd.get<scalar>("freeSurfaceLevel");
        if (mag(g_) < SMALL)
        {
            FatalIOErrorInFunction(hd)
                << "g " << g_ << " has zero length." << exit(FatalIOError);
        }
    }

    return true;
}


bool Foam::functionObjects::tqInterface::execute()
{
    // What this function object and the exchange print is never silenced
    messageStream::level = infoLevel_;

    calcLoads();

    const scalar t = time().value();
    const scalar dt = time().deltaTValue();
    const bool coupled = exchange_->isCouplingOngoing();

    bool accepted = true;
    if (coupled)
    {
        exchange_->writeForces(t, pointForce_);
        exchange_->advance(dt);
        accepted = !exchange_->requiresReadingCheckpoint();
    }

    writeRow(t, accepted);

    if (accepted)
    {
        const bool rewrite =
            rewriteTime_ >= 0 && mag(t - rewriteTime_) < 0.5*dt;
        if (time().writeTime() || rewrite)
        {
            writeFields();
        }
        if (rewrite)
        {
            // This write time was written by a rejected attempt
            const_cast<Time&>(time()).writeNow();
            rewriteTime_ = -1;
        }
    }
    else
    {
        if (time().writeTime())
        {
            rewriteTime_ = t;
        }
        checkpoint_.restore();
        ++nRollbacks_;
    }

    if (coupled)
    {
        const bool partnerDone = !exchange_->isCouplingOngoing();
        if (accepted && (t >= endTime_ - 0.5*dt || partnerDone))
        {
            if (partnerDone && t < endTime_ - 0.5*dt)
            {
                Info<< type() << " " << name() << ": the coupling ended at t = "
                    << t << " s (before endTime " << endTime_ << " s)" << endl;
            }
            exchange_->finalize();
            const_cast<Time&>(time()).writeAndEnd();
            return true;
        }
        if (exchange_->requiresWritingCheckpoint())
        {
            checkpoint_.store();
        }
        if (restartWindows_ > 0)
        {
            const label n = exchange_->windowsCompleted();
            if (n > lastRestartWindow_ && n % restartWindows_ == 0)
            {
                // A scheme that never steps a window again (explicit)
                // saves no state each window: the accepted one is saved
                // here for the restart file
                if (!exchange_->requiresWritingCheckpoint())
                {
                    checkpoint_.store();
                }
                writeRestart(n);
            }
        }
        receiveMotion();
    }

    setSolverOutput();
    return true;
}


bool Foam::functionObjects::tqInterface::write()
{
    return true;
}


bool Foam::functionObjects::tqInterface::end()
{
    messageStream::level = infoLevel_;
    if (filePtr_.valid())
    {
        filePtr_().flush();
    }
    if (exchange_.valid())
    {
        exchange_->finalize();
    }
    return true;
}


namespace
{

const char fluidRestartMagic[8] = {'T', 'Q', 'F', 'L', 'U', 'I', 'D', '1'};
const char fluidRestartEnd[8] = {'T', 'Q', 'F', 'L', 'E', 'N', 'D', '1'};
// The trailer after fluidRestartEnd: the input fingerprint's digest (64 bytes, space-padded), these
// 8 bytes, and the CRC-32 (u32) of every byte before it
const char fluidRestartSum[8] = {'T', 'Q', 'F', 'L', 'S', 'U', 'M', '1'};
constexpr size_t fluidDigestBytes = 64;
constexpr size_t fluidTrailerBytes = fluidDigestBytes + sizeof fluidRestartSum + sizeof(std::uint32_t);

std::string paddedDigest(const std::string& d)
{
    std::string s(d.substr(0, fluidDigestBytes));
    s.resize(fluidDigestBytes, ' ');
    return s;
}

void putString(std::ostream& os, const std::string& s)
{
    const std::int64_t n = std::int64_t(s.size());
    os.write(reinterpret_cast<const char*>(&n), sizeof n);
    os.write(s.data(), std::streamsize(s.size()));
}

template<class T>
bool getValue(std::istream& is, T& v)
{
    return bool(is.read(reinterpret_cast<char*>(&v), sizeof(T)));
}

bool getString(std::istream& is, std::string& s)
{
    std::int64_t n = 0;
    if (!getValue(is, n) || n < 0 || n > (std::int64_t(1) << 36))
    {
        return false;
    }
    s.resize(size_t(n));
    return n == 0 || bool(is.read(&s[0], std::streamsize(n)));
}

// A decomposed water's checkpoint: these 8 bytes, the rank count (i64), then
// each rank's part (i64 size and bytes: what follows fluidRestartMagic in a
// one-rank file, up to and with fluidRestartEnd), then the one trailer
const char fluidRanksMagic[8] = {'T', 'Q', 'F', 'L', 'U', 'I', 'D', 'R'};

// The tag of the messages carrying the ranks' parts to and from the master
constexpr int restartTag = 7317;
// The largest message: MPI counts bytes in an int
constexpr size_t restartChunk = size_t(1) << 30;

void sendBytes(const int to, const std::string& s)
{
    const std::int64_t n = std::int64_t(s.size());
    bool ok = Foam::UOPstream::write
    (
        Foam::UPstream::commsTypes::scheduled, to,
        reinterpret_cast<const char*>(&n), sizeof n, restartTag
    );
    for (size_t done = 0; ok && done < s.size(); done += restartChunk)
    {
        ok = Foam::UOPstream::write
        (
            Foam::UPstream::commsTypes::scheduled, to, s.data() + done,
            std::streamsize(std::min(restartChunk, s.size() - done)),
            restartTag
        );
    }
    if (!ok)
    {
        FatalErrorInFunction
            << "Cannot send rank " << Foam::Pstream::myProcNo() << "'s part of"
            << " the restart checkpoint to rank " << to << "."
            << Foam::exit(Foam::FatalError);
    }
}

std::string receiveBytes(const int from)
{
    std::int64_t n = -1;
    Foam::UIPstream::read
    (
        Foam::UPstream::commsTypes::scheduled, from,
        reinterpret_cast<char*>(&n), sizeof n, restartTag
    );
    if (n < 0)
    {
        FatalErrorInFunction
            << "No size of rank " << from << "'s part of the restart"
            << " checkpoint." << Foam::exit(Foam::FatalError);
    }
    std::string s(size_t(n), '\0');
    for (size_t done = 0; done < s.size(); done += restartChunk)
    {
        const size_t want = std::min(restartChunk, s.size() - done);
        const Foam::label got = Foam::UIPstream::read
        (
            Foam::UPstream::commsTypes::scheduled, from, &s[done],
            std::streamsize(want), restartTag
        );
        if (got != Foam::label(want))
        {
            FatalErrorInFunction
                << "Rank " << from << "'s part of the restart checkpoint came"
                << " short (" << got << " of " << want << " bytes)."
                << Foam::exit(Foam::FatalError);
        }
    }
    return s;
}

Foam::word restartName(const Foam::label n)
{
    char buf[40];
    std::snprintf(buf, sizeof buf, "fluid-%09ld.bin", long(n));
    return buf;
}

} // End anonymous namespace


void Foam::functionObjects::tqInterface::writeRestart(const label n)
{
    if (restartDir_.empty())
    {
        FatalErrorInFunction
            << "restartWindows " << restartWindows_ << " needs restartDir"
            << " (the folder of the restart checkpoints)." << exit(FatalError);
    }
    std::string rows;
    if (filePtr_.valid())
    {
        filePtr_().flush();
        std::ifstream in(filePtr_().name(), std::ios::binary);
        std::ostringstream all;
        all << in.rdbuf();
        rows = all.str();
    }
    // This rank's part: on ranks each holds its cells' fields, its points'
    // motion and its part of the exchange (interface.dat: the master's)
    std::string part;
    {
        std::ostringstream os;
        const std::int64_t window = n, rollbacks = nRollbacks_;
        os.write(reinterpret_cast<const char*>(&window), sizeof window);
        os.write(reinterpret_cast<const char*>(&rollbacks), sizeof rollbacks);
        os.write(reinterpret_cast<const char*>(&rewriteTime_), sizeof rewriteTime_);
        os.write(reinterpret_cast<const char*>(&nextLogTime_), sizeof nextLogTime_);
        putString(os, exchange_->saveState());
        putString(os, rows);
        checkpoint_.write(os);
        os.write(fluidRestartEnd, sizeof fluidRestartEnd);
        part = os.str();
    }
    prevRestartWindow_ = lastRestartWindow_;
    lastRestartWindow_ = n;
    if (!Pstream::master())
    {
        // The master writes every rank's part into the one file, renamed
        // whole: a checkpoint holds all ranks or is not there
        sendBytes(Pstream::masterNo(), part);
        return;
    }
    std::ostringstream os;
    if (Pstream::parRun())
    {
        os.write(fluidRanksMagic, sizeof fluidRanksMagic);
        const std::int64_t ranks = Pstream::nProcs();
        os.write(reinterpret_cast<const char*>(&ranks), sizeof ranks);
        putString(os, part);
        part.clear();
        for (label proci = 1; proci < Pstream::nProcs(); ++proci)
        {
            putString(os, receiveBytes(int(proci)));
        }
    }
    else
    {
        os.write(fluidRestartMagic, sizeof fluidRestartMagic);
        os.write(part.data(), std::streamsize(part.size()));
        part.clear();
    }
    os << paddedDigest(inputFingerprint_);
    os.write(fluidRestartSum, sizeof fluidRestartSum);
    std::string bytes(os.str());
    const std::uint32_t crc = ::tq::crc::crc32(bytes.data(), bytes.size());
    bytes.append(reinterpret_cast<const char*>(&crc), sizeof crc);

    mkDir(restartDir_);
    const std::string path(restartDir_/restartName(n));
    const std::string tmp(path + ".tmp");
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    bool ok = fd >= 0;
    size_t done = 0;
    while (ok && done < bytes.size())
    {
        const ssize_t w = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (w < 0 && errno == EINTR)
        {
            continue;
        }
        ok = w > 0;
        done += ok ? size_t(w) : 0;
    }
    ok = ok && ::fsync(fd) == 0;
    if (fd >= 0)
    {
        ::close(fd);
    }
    // Test hook (docs/reliability.md "Restart"): TQ_CHECKPOINT_FAULT=<window>:water
    // kills the water (SIGKILL, as a lost node) once it wrote that window's
    // checkpoint under its temporary name, before the rename
    if (const char* fault = std::getenv("TQ_CHECKPOINT_FAULT"))
    {
        if (std::to_string(n) + ":water" == fault)
        {
            std::raise(SIGKILL);
        }
    }
    if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0)
    {
        FatalErrorInFunction
            << "Cannot write the restart checkpoint " << path << ": "
            << std::strerror(errno) << exit(FatalError);
    }
    // The last two are kept: the solid's last checkpoint may be one ahead
    for (const fileName& f : readDir(restartDir_, fileName::FILE))
    {
        const std::string name(f);
        if
        (
            name.rfind("fluid-", 0) == 0
         && name != restartName(n)
         && (prevRestartWindow_ < 0 || name != restartName(prevRestartWindow_))
        )
        {
            Foam::rm(restartDir_/f);
        }
    }
}


std::string Foam::functionObjects::tqInterface::readRestart
(
    const fileName& file,
    const polyPatch& pp,
    const scalarField& pointArea
)
{
    // The master reads and checks the file, then hands each rank its part
    const label nRanks = Pstream::nProcs();
    std::string damage, fix("run again without --resume");
    std::vector<std::string> parts;
    if (Pstream::master())
    {
        std::string whole;
        {
            std::ifstream in(file, std::ios::binary);
            std::ostringstream all;
            all << in.rdbuf();
            whole = all.str();
        }
        if (whole.size() < sizeof fluidRestartMagic + fluidTrailerBytes)
        {
            damage = "it is missing or cut short (" + std::to_string(whole.size()) + " bytes)";
        }
        else
        {
            const size_t body = whole.size() - sizeof(std::uint32_t);
            std::uint32_t want = 0;
            std::memcpy(&want, whole.data() + body, sizeof want);
            const std::uint32_t got = ::tq::crc::crc32(whole.data(), body);
            if
            (
                std::memcmp
                (
                    whole.data() + body - sizeof fluidRestartSum,
                    fluidRestartSum,
                    sizeof fluidRestartSum
                ) != 0
            )
            {
                damage = "it does not end with the checkpoint's checksum (cut short or damaged)";
            }
            else if (got != want)
            {
                damage = "its CRC-32 is " + ::tq::crc::hex(got) + " instead of the "
                    + ::tq::crc::hex(want) + " it records (the file is damaged)";
            }
            else if
            (
                whole.compare
                (
                    body - sizeof fluidRestartSum - fluidDigestBytes,
                    fluidDigestBytes,
                    paddedDigest(inputFingerprint_)
                ) != 0
            )
            {
                damage = "it was written for other inputs (input fingerprint "
                    + whole.substr(body - sizeof fluidRestartSum - fluidDigestBytes, 16)
                    + "..., this run " + inputFingerprint_.substr(0, 16) + "...)";
            }
        }
        if (damage.empty())
        {
            whole.resize(whole.size() - fluidTrailerBytes);
            std::istringstream is(whole);
            whole.clear();
            char magic[sizeof fluidRestartMagic];
            is.read(magic, sizeof magic);
            std::int64_t written = 0;
            if (std::memcmp(magic, fluidRestartMagic, sizeof magic) == 0)
            {
                written = 1;
                parts.emplace_back(std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>());
            }
            else if
            (
                std::memcmp(magic, fluidRanksMagic, sizeof magic) != 0
             || !getValue(is, written)
             || written < 1
            )
            {
                damage = "it is not a restart checkpoint of the water (or a damaged one)";
            }
            else if (written == std::int64_t(nRanks))
            {
                parts.resize(size_t(written));
                for (std::string& p : parts)
                {
                    if (!getString(is, p))
                    {
                        damage = "a rank's part of it is cut short (a damaged file)";
                        break;
                    }
                }
            }
            if (damage.empty() && written != std::int64_t(nRanks))
            {
                damage = "it was written by the water on " + std::to_string(written)
                    + " rank(s), and this run has it on " + std::to_string(nRanks)
                    + " (parallel.fluid_ranks): a rank's part is its cells' state";
                fix = "resume with parallel.fluid_ranks: " + std::to_string(written)
                    + " as it was written, or run again without --resume";
            }
        }
    }
    if (Pstream::parRun())
    {
        string says(damage), fixes(fix);
        Pstream::scatter(says);
        Pstream::scatter(fixes);
        damage = says;
        fix = fixes;
    }
    if (!damage.empty())
    {
        FatalErrorInFunction
            << "Cannot resume from " << file << ": " << damage.c_str() << "." << nl
            << "Fix: " << fix.c_str() << "." << exit(FatalError);
    }
    std::string mine;
    if (Pstream::master())
    {
        for (label proci = 1; proci < nRanks; ++proci)
        {
            sendBytes(int(proci), parts[size_t(proci)]);
            parts[size_t(proci)].clear();
        }
        mine.swap(parts[0]);
    }
    else
    {
        mine = receiveBytes(Pstream::masterNo());
    }
    std::istringstream is(mine);
    mine.clear();
    std::int64_t window = 0, rollbacks = 0;
    std::string exchangeState, rows;
    if
    (
        !is
     || !getValue(is, window)
     || !getValue(is, rollbacks)
     || !getValue(is, rewriteTime_)
     || !getValue(is, nextLogTime_)
     || !getString(is, exchangeState)
     || !getString(is, rows)
    )
    {
        FatalErrorInFunction
            << "Cannot resume from " << file << ": missing, or not a restart"
            << " checkpoint of the water (or a damaged one)." << nl
            << "Fix: run again without --resume." << exit(FatalError);
    }
    nRollbacks_ = label(rollbacks);
    exchange_->initializeResumed(pp, points0_, pointArea, exchangeState);
    checkpoint_.readAndRestore(is);
    char last[sizeof fluidRestartEnd];
    if
    (
        !is.read(last, sizeof last)
     || std::memcmp(last, fluidRestartEnd, sizeof last) != 0
     || is.peek() != std::char_traits<char>::eof()
    )
    {
        FatalErrorInFunction
            << "Cannot resume from " << file << ": it does not end as a"
            << " restart checkpoint of the water does (a damaged file)." << nl
            << "Fix: run again without --resume." << exit(FatalError);
    }
    lastRestartWindow_ = label(window);
    Info<< type() << " " << name() << ": resumed from " << file
        << " at t = " << time().value() << " s (coupling window " << window;
    if (Pstream::parRun())
    {
        Info<< ", the water on " << nRanks << " ranks";
    }
    Info<< ")" << endl;
    return rows;
}


// ************************************************************************* //
