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

#include "replayExchange.H"
#include "addToRunTimeSelectionTable.H"
#include "DynamicList.H"

#include <fstream>
#include <sstream>
#include <string>

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
    defineTypeNameAndDebug(replayExchange, 0);
    addToRunTimeSelectionTable(interfaceExchange, replayExchange, dictionary);
}
}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::tq::replayExchange::readTable()
{
    std::ifstream is(file_.c_str());
    if (!is.good())
    {
        FatalIOErrorInFunction(dict_)
            << "Cannot open the wall motion file '" << file_ << "' (entry"
            << " 'file' of " << dict_.name() << ")." << nl
            << "Fix: give the path of a table"
            << " 't ux uy uz vx vy vz [ur vr [uo vo]]'."
            << exit(FatalIOError);
    }

    DynamicList<scalar> t;
    DynamicList<vector> d, v;
    DynamicList<scalar> rd, rv, od, ov;
    label nCols = -1;
    std::string line;
    label lineNo = 0;
    while (std::getline(is, line))
    {
        ++lineNo;
        const auto hash = line.find('#');
        if (hash != std::string::npos)
        {
            line.erase(hash);
        }
        std::istringstream ls(line);
        std::vector<double> row;
        double x;
        while (ls >> x)
        {
            row.push_back(x);
        }
        if (!ls.eof())
        {
            FatalErrorInFunction
                << file_ << " line " << lineNo << ": not a number in '"
                << line << "'." << exit(FatalError);
        }
        if (row.empty())
        {
            continue;
        }
        const label n = label(row.size());
        if ((n != 7 && n != 9 && n != 11) || (nCols != -1 && n != nCols))
        {
            FatalErrorInFunction
                << file_ << " line " << lineNo << ": " << n << " columns;"
                << " expected 7 (t ux uy uz vx vy vz), 9 (... ur vr) or 11"
                << " (... ur vr uo vo), the same on every row."
                << exit(FatalError);
        }
        nCols = n;
        if (t.size() && row[0] <= t.last())
        {
            FatalErrorInFunction
                << file_ << " line " << lineNo << ": time " << row[0]
                << " does not increase (previous " << t.last() << ")."
                << exit(FatalError);
        }
        t.append(row[0]);
        d.append(vector(row[1], row[2], row[3]));
        v.append(vector(row[4], row[5], row[6]));
        rd.append(n >= 9 ? row[7] : 0.0);
        rv.append(n >= 9 ? row[8] : 0.0);
        od.append(n == 11 ? row[9] : 0.0);
        ov.append(n == 11 ? row[10] : 0.0);
    }

    if (t.size() < 2)
    {
        FatalErrorInFunction
            << file_ << ": needs at least two rows, has " << t.size() << "."
            << exit(FatalError);
    }

    times_.transfer(t);
    disp_.transfer(d);
    vel_.transfer(v);
    radialDisp_.transfer(rd);
    radialVel_.transfer(rv);
    ovalDisp_.transfer(od);
    ovalVel_.transfer(ov);
}


void Foam::tq::replayExchange::bracket
(
    const scalar t,
    label& i0,
    scalar& w1
) const
{
    const scalar tol = 1e-9*max(mag(times_.last() - times_.first()), SMALL);
    if (t < times_.first() - tol || t > times_.last() + tol)
    {
        FatalErrorInFunction
            << "Time " << t << " is outside the wall motion table "
            << file_ << " (" << times_.first() << " to " << times_.last()
            << " s)." << nl << "Fix: extend the table or shorten endTime."
            << exit(FatalError);
    }

    // Binary search for times_[i0] <= t < times_[i0 + 1]
    label lo = 0;
    label hi = times_.size() - 1;
    while (hi - lo > 1)
    {
        const label mid = (lo + hi)/2;
        if (times_[mid] <= t)
        {
            lo = mid;
        }
        else
        {
            hi = mid;
        }
    }
    i0 = lo;
    w1 = (t - times_[lo])/(times_[hi] - times_[lo]);
    w1 = min(max(w1, 0.0), 1.0);
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tq::replayExchange::replayExchange
(
    const Time& runTime,
    const dictionary& dict
)
:
    interfaceExchange(runTime, dict),
    file_(dict.get<fileName>("file").expand()),
    axisPoint_(dict.lookupOrDefault<point>("axisPoint", Zero)),
    axisDirection_
    (
        dict.lookupOrDefault<vector>("axisDirection", vector(0, 1, 0))
    ),
    thetaZero_(dict.lookupOrDefault<vector>("thetaZero", vector(1, 0, 0))),
    rollbacksPerStep_(dict.lookupOrDefault<label>("rollbacksPerStep", 0)),
    predictorScale_(dict.lookupOrDefault<scalar>("predictorScale", 1.0)),
    rollbackFromStep_(dict.lookupOrDefault<label>("rollbackFromStep", 1)),
    attempt_(0),
    nAccepted_(0)
{
    if (mag(axisDirection_) < SMALL)
    {
        FatalIOErrorInFunction(dict)
            << "axisDirection " << axisDirection_ << " has zero length."
            << exit(FatalIOError);
    }
    axisDirection_ /= mag(axisDirection_);

    thetaZero_ -= (thetaZero_ & axisDirection_)*axisDirection_;
    if (mag(thetaZero_) < SMALL)
    {
        FatalIOErrorInFunction(dict)
            << "thetaZero is parallel to the axis " << axisDirection_
            << exit(FatalIOError);
    }
    thetaZero_ /= mag(thetaZero_);

    if (rollbacksPerStep_ < 0)
    {
        FatalIOErrorInFunction(dict)
            << "rollbacksPerStep " << rollbacksPerStep_
            << " must be 0 or more." << exit(FatalIOError);
    }

    readTable();
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::tq::replayExchange::initialize
(
    const polyPatch&,
    const pointField& points0,
    const scalarField& pointAreas
)
{
    radialDir_.setSize(points0.size());
    ovalShape_.setSize(points0.size());
    const vector thetaNinety(axisDirection_ ^ thetaZero_);
    forAll(points0, i)
    {
        vector r = points0[i] - axisPoint_;
        r -= (r & axisDirection_)*axisDirection_;
        const scalar magR = mag(r);
        radialDir_[i] = (magR > SMALL ? r/magR : vector::zero);

        // theta from thetaZero towards axis x thetaZero; e_t = axis x e_r
        const vector et(axisDirection_ ^ radialDir_[i]);
        const scalar theta =
            ::atan2(radialDir_[i] & thetaNinety, radialDir_[i] & thetaZero_);
        ovalShape_[i] =
            ::cos(2*theta)*radialDir_[i] - 0.5*::sin(2*theta)*et;
    }
    lastForces_.setSize(points0.size(), Zero);

    // Save the initial state when the first step is to be repeated
    writeCheckpoint_ = (stepRollbacks(1) > 0);
}


void Foam::tq::replayExchange::writeForces
(
    const scalar,
    const vectorField& forces
)
{
    lastForces_ = forces;
}


void Foam::tq::replayExchange::advance(const scalar)
{
    ++attempt_;
    if (attempt_ <= stepRollbacks(nAccepted_ + 1))
    {
        readCheckpoint_ = true;
        writeCheckpoint_ = false;
    }
    else
    {
        attempt_ = 0;
        ++nAccepted_;
        readCheckpoint_ = false;
        writeCheckpoint_ = (stepRollbacks(nAccepted_ + 1) > 0);
    }
}


void Foam::tq::replayExchange::readMotion
(
    const scalar t,
    vectorField& displacement,
    vectorField& velocity
)
{
    label i0;
    scalar w1;
    bracket(t, i0, w1);
    const label i1 = min(i0 + 1, times_.size() - 1);
    const scalar w0 = 1 - w1;

    scalar scale = 1;
    if (stepRollbacks(nAccepted_ + 1) > 0 && attempt_ == 0)
    {
        scale = predictorScale_;
    }

    const vector d = scale*(w0*disp_[i0] + w1*disp_[i1]);
    const vector v = scale*(w0*vel_[i0] + w1*vel_[i1]);
    const scalar rd = scale*(w0*radialDisp_[i0] + w1*radialDisp_[i1]);
    const scalar rv = scale*(w0*radialVel_[i0] + w1*radialVel_[i1]);
    const scalar od = scale*(w0*ovalDisp_[i0] + w1*ovalDisp_[i1]);
    const scalar ov = scale*(w0*ovalVel_[i0] + w1*ovalVel_[i1]);

    displacement.setSize(radialDir_.size());
    velocity.setSize(radialDir_.size());
    forAll(radialDir_, i)
    {
        displacement[i] = d + rd*radialDir_[i] + od*ovalShape_[i];
        velocity[i] = v + rv*radialDir_[i] + ov*ovalShape_[i];
    }
}


// ************************************************************************* //
