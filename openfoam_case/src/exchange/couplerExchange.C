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

// The coupler's headers first: plain C++17, parsed before OpenFOAM's macros
#include "tq/coupler/errors.hpp"
#include "tq/coupler/participant.hpp"

#include "couplerExchange.H"
#include "addToRunTimeSelectionTable.H"
#include "polyMesh.H"
#include "globalMeshData.H"
#include "globalIndex.H"
#include "Pstream.H"
#include "PstreamBuffers.H"
#include "ops.H"
#include "OSspecific.H"

#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>
#include <cstdlib>
#include <time.h>

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
    defineTypeNameAndDebug(couplerExchange, 0);
    addToRunTimeSelectionTable(interfaceExchange, couplerExchange, dictionary);
}
}


// * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * * //

namespace
{

std::string str(const Foam::string& s)
{
    return std::string(s.c_str());
}

double threadCpu()
{
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9*double(ts.tv_nsec);
}

double wallNow()
{
    return std::chrono::duration<double>
    (
        std::chrono::steady_clock::now().time_since_epoch()
    ).count();
}

//- The water's ranks as the parts of one participant: their exact sums'
//  integer limbs added over every rank (integers: any order gives the same)
class PstreamGroup
:
    public ::tq::coupler::PartGroup
{
public:
    void sumAll(std::vector<std::int64_t>& values) override
    {
        Foam::List<std::int64_t> v(Foam::label(values.size()));
        forAll(v, i)
        {
            v[i] = values[i];
        }
        Foam::Pstream::listCombineGather(v, Foam::plusEqOp<std::int64_t>());
        Foam::Pstream::listCombineScatter(v);
        forAll(v, i)
        {
            values[i] = v[i];
        }
    }
};

} // End anonymous namespace


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::tq::couplerExchange::fail
(
    const std::string& where,
    const std::string& what
) const
{
    FatalErrorInFunction
        << "Coupling with the solid failed in " << where.c_str() << ":" << nl
        << "    " << what.c_str() << nl
        << "The partner has been told (ABORT) where the link still works."
        << exit(FatalError);
}


void Foam::tq::couplerExchange::enterCall()
{
    const double now = wallNow();
    secondsSolver_ += now - clockLast_;
    clockLast_ = now;
    cpuCallStart_ = threadCpu();
}


void Foam::tq::couplerExchange::leaveCall()
{
    const double now = wallNow();
    secondsInside_ += now - clockLast_;
    clockLast_ = now;
    cpuInside_ += threadCpu() - cpuCallStart_;
}


void Foam::tq::couplerExchange::reportCost() const
{
    if (!Pstream::master() || !participant_ || passes_ < 1)
    {
        return;
    }
    const ::tq::coupler::ExchangeStats xs = participant_->stats();
    const double wait = xs.secondsWaiting - waitAtStart_;
    const double work = secondsInside_ - wait;
    const double per = 1e3/double(passes_);
    Info<< "couplerExchange: cost over " << passes_ << " passes: water solve "
        << secondsSolver_ << " s (" << secondsSolver_*per
        << " ms a pass); exchange calls " << secondsInside_
        << " s, of which waiting for the solid " << wait
        << " s; exchange work " << work << " s (" << work*per
        << " ms a pass; mapping " << xs.secondsMapping - mappingAtStart_
        << " s); CPU in the exchange calls " << cpuInside_ << " s ("
        << cpuInside_*per << " ms a pass)" << endl;
}


void Foam::tq::couplerExchange::syncFlags()
{
    if (parts_)
    {
        // every part follows the same decisions of the second's scheme
        readCheckpoint_ = participant_->requiresReadingCheckpoint();
        writeCheckpoint_ = participant_->requiresWritingCheckpoint();
        ongoing_ = participant_->isCouplingOngoing();
        return;
    }
    if (Pstream::master())
    {
        readCheckpoint_ = participant_->requiresReadingCheckpoint();
        writeCheckpoint_ = participant_->requiresWritingCheckpoint();
        ongoing_ = participant_->isCouplingOngoing();
    }
    Pstream::scatter(readCheckpoint_);
    Pstream::scatter(writeCheckpoint_);
    Pstream::scatter(ongoing_);
}


void Foam::tq::couplerExchange::sendSublists
(
    PstreamBuffers& bufs,
    const vectorField& values,
    const labelListList& lists
)
{
    for (label proci = 0; proci < Pstream::nProcs(); ++proci)
    {
        if (proci != Pstream::myProcNo())
        {
            UOPstream os(proci, bufs);
            os << vectorField(values, lists[proci]);
        }
    }
    bufs.finishedSends();
}


Foam::tmp<Foam::vectorField> Foam::tq::couplerExchange::spreadOwned
(
    const vectorField& owned
) const
{
    const label me = Pstream::myProcNo();
    PstreamBuffers bufs(Pstream::commsTypes::nonBlocking);
    sendSublists(bufs, owned, recvFrom_);
    tmp<vectorField> tlocal(new vectorField(pointToGlobal_.size(), Zero));
    vectorField& local = tlocal.ref();
    forAll(ownedLocal_, k)
    {
        local[ownedLocal_[k]] = owned[k];
    }
    for (label proci = 0; proci < Pstream::nProcs(); ++proci)
    {
        if (proci != me)
        {
            UIPstream is(proci, bufs);
            vectorField part(is);
            forAll(part, j)
            {
                local[sendTo_[proci][j]] = part[j];
            }
        }
    }
    return tlocal;
}


Foam::tmp<Foam::vectorField> Foam::tq::couplerExchange::readLocal
(
    const word& field
)
{
    if (parts_)
    {
        std::vector<double> v;
        try
        {
            participant_->readData(meshName_, field, v);
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("readData", e.what());
        }
        vectorField owned(ownedLocal_.size());
        if (v.size() != 3*owned.size())
        {
            fail
            (
                "readData",
                "field '" + field + "' has " + std::to_string(v.size())
              + " values for this rank's " + std::to_string(owned.size())
              + " points x 3"
            );
        }
        forAll(owned, k)
        {
            owned[k] = vector(v[3*k], v[3*k + 1], v[3*k + 2]);
        }
        return spreadOwned(owned);
    }
    vectorField global(nGlobal_, Zero);
    if (Pstream::master())
    {
        std::vector<double> v;
        try
        {
            participant_->readData(meshName_, field, v);
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("readData", e.what());
        }
        if (label(v.size()) != 3*nGlobal_)
        {
            fail
            (
                "readData",
                "field '" + field + "' has " + std::to_string(v.size())
              + " values for " + std::to_string(nGlobal_) + " points x 3"
            );
        }
        forAll(global, i)
        {
            global[i] = vector(v[3*i], v[3*i + 1], v[3*i + 2]);
        }
    }
    Pstream::scatter(global);
    return tmp<vectorField>(new vectorField(global, pointToGlobal_));
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tq::couplerExchange::couplerExchange
(
    const Time& runTime,
    const dictionary& dict
)
:
    interfaceExchange(runTime, dict),
    participant_(),
    name_(dict.lookupOrDefault<word>("participant", "fluid")),
    meshName_(dict.lookupOrDefault<word>("mesh", "wall")),
    readFields_
    (
        dict.lookupOrDefault<wordList>("readFields", wordList{"velocity"})
    ),
    writeFields_
    (
        dict.lookupOrDefault<wordList>("writeFields", wordList{"force"})
    ),
    readsDisplacement_(false),
    windowSize_
    (
        dict.lookupOrDefault<scalar>("windowSize", runTime.deltaTValue())
    ),
    startTime_(runTime.value()),
    parts_(Pstream::parRun() && Foam::getEnv("TQ_WATER_GATHER") != "1"),
    pointToGlobal_(),
    ownedLocal_(),
    ownedStart_(0),
    sendTo_(),
    recvFrom_(),
    nGlobal_(0),
    windowStart_(runTime.value()),
    ongoing_(false),
    finalized_(false),
    clockLast_(0),
    secondsSolver_(0),
    secondsInside_(0),
    cpuInside_(0),
    cpuCallStart_(0),
    waitAtStart_(0),
    mappingAtStart_(0),
    passes_(0),
    windowsDone_(0),
    resumeState_()
{
    if (!readFields_.found("velocity"))
    {
        FatalIOErrorInFunction(dict)
            << "readFields " << readFields_ << " must contain 'velocity' (the"
            << " wall velocity of the solid)." << exit(FatalIOError);
    }
    readsDisplacement_ = readFields_.found("displacement");
    if (writeFields_.size() != 1)
    {
        FatalIOErrorInFunction(dict)
            << "writeFields " << writeFields_ << ": give the one force field"
            << " (e.g. (force))." << exit(FatalIOError);
    }
    if (windowSize_ < runTime.deltaTValue()*(1 - 1e-9))
    {
        FatalIOErrorInFunction(dict)
            << "windowSize " << windowSize_ << " s is smaller than the fluid"
            << " step deltaT " << runTime.deltaTValue() << " s." << nl
            << "Fix: a coupling window holds one or more fluid steps."
            << exit(FatalIOError);
    }
}


Foam::tq::couplerExchange::~couplerExchange()
{
    // Participant's destructor sends ABORT when not finalized
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::tq::couplerExchange::initialize
(
    const polyPatch& patch,
    const pointField& points0,
    const scalarField&
)
{
    // Unique numbering of the interface points over all ranks
    labelList uniqueMeshPoints;
    autoPtr<globalIndex> gi = patch.boundaryMesh().mesh().globalData()
        .mergePoints
        (
            patch.meshPoints(),
            patch.meshPointMap(),
            pointToGlobal_,
            uniqueMeshPoints
        );
    nGlobal_ = gi().size();

    windowDisplacement_.setSize(points0.size(), Zero);
    lastDisplacement_.setSize(points0.size(), Zero);

    std::vector<std::int64_t> ids;
    std::vector<double> xyz;
    if (parts_)
    {
        // This rank's part: the points it owns, in global order; the
        // shared points' other holders told which of their points it owns
        const label me = Pstream::myProcNo();
        ownedStart_ = gi().offset(me);
        ownedLocal_.setSize(gi().localSize(me), -1);
        List<DynamicList<label>> sendTo(Pstream::nProcs());
        forAll(pointToGlobal_, i)
        {
            const label g = pointToGlobal_[i];
            if (gi().isLocal(me, g))
            {
                ownedLocal_[g - ownedStart_] = i;
            }
            else
            {
                sendTo[gi().whichProcID(g)].append(i);
            }
        }
        sendTo_.setSize(Pstream::nProcs());
        recvFrom_.setSize(Pstream::nProcs());
        PstreamBuffers bufs(Pstream::commsTypes::nonBlocking);
        for (label proci = 0; proci < Pstream::nProcs(); ++proci)
        {
            sendTo_[proci].transfer(sendTo[proci]);
            if (proci != me)
            {
                UOPstream os(proci, bufs);
                os << labelList(UIndirectList<label>(pointToGlobal_, sendTo_[proci]));
            }
        }
        bufs.finishedSends();
        for (label proci = 0; proci < Pstream::nProcs(); ++proci)
        {
            if (proci != me)
            {
                UIPstream is(proci, bufs);
                labelList g(is);
                forAll(g, j)
                {
                    g[j] -= ownedStart_;
                }
                recvFrom_[proci].transfer(g);
            }
        }
        ids.resize(ownedLocal_.size());
        xyz.resize(3*ownedLocal_.size());
        forAll(ownedLocal_, k)
        {
            if (ownedLocal_[k] < 0)
            {
                fail
                (
                    "initialize",
                    "global interface point " + std::to_string(ownedStart_ + k)
                  + " of this rank's range has no local point"
                );
            }
            const point& x = points0[ownedLocal_[k]];
            ids[k] = ownedStart_ + k;
            xyz[3*k] = x.x();
            xyz[3*k + 1] = x.y();
            xyz[3*k + 2] = x.z();
        }
    }
    else
    {
    // Reference coordinates of every interface point, on the master
    List<labelList> procIds(Pstream::nProcs());
    List<pointField> procPoints(Pstream::nProcs());
    procIds[Pstream::myProcNo()] = pointToGlobal_;
    procPoints[Pstream::myProcNo()] = points0;
    Pstream::gatherList(procIds);
    Pstream::gatherList(procPoints);

    if (Pstream::master())
    {
        ids.resize(nGlobal_);
        xyz.assign(3*nGlobal_, 0.0);
        forAll(procIds, proci)
        {
            forAll(procIds[proci], i)
            {
                const label g = procIds[proci][i];
                const point& x = procPoints[proci][i];
                xyz[3*g] = x.x();
                xyz[3*g + 1] = x.y();
                xyz[3*g + 2] = x.z();
            }
        }
        for (label g = 0; g < nGlobal_; ++g)
        {
            ids[g] = g;
        }
    }
    }

    if (holds())
    {
        // The coupling configuration, item by item from the dictionary
        ::tq::coupler::CouplingConfig c;
        const word partner(dict_.lookupOrDefault<word>("partner", "solid"));
        c.first = partner;
        c.second = name_;
        c.units = str(dict_.lookupOrDefault<string>("units", "SI(m,kg,s,N,Pa)"));
        c.windowSize = windowSize_;
        {
            const scalar span = time_.endTime().value() - startTime_;
            const label nDefault = label(std::llround(span/windowSize_));
            c.maxWindows = dict_.lookupOrDefault<label>("windows", nDefault);
        }
        c.maxIterations = dict_.lookupOrDefault<label>("maxIterations", 20);
        c.tolerance = dict_.lookupOrDefault<scalar>("tolerance", 1e-4);
        c.initialRelaxation =
            dict_.lookupOrDefault<scalar>("initialRelaxation", 0.5);
        c.reuse = dict_.lookupOrDefault<label>("reuse", 0);

        ::tq::coupler::TransportOptions t;
        try
        {
            c.scheme = ::tq::coupler::parseScheme
            (
                dict_.lookupOrDefault<word>("scheme", "explicit")
            );
            c.acceleration = ::tq::coupler::parseAcceleration
            (
                dict_.lookupOrDefault<word>("acceleration", "aitken")
            );
            c.predictor = ::tq::coupler::parsePredictor
            (
                dict_.lookupOrDefault<word>("predictor", "constant")
            );
            c.residualScale = ::tq::coupler::parseResidualScale
            (
                dict_.lookupOrDefault<word>("residualScale", "current")
            );
            ::tq::coupler::MeshSpec m;
            m.name = meshName_;
            m.mapping = ::tq::coupler::parseMapKind
            (
                dict_.lookupOrDefault<word>("map", "coincident")
            );
            m.mappingSide =
                str(dict_.lookupOrDefault<string>("mappingSide", ""));
            m.tolerance = dict_.lookupOrDefault<scalar>("mapTolerance", 1e-6);
            c.meshes.push_back(m);
            // Implicit scheme: absolute convergence floor per field, in
            // the field's units (absoluteTolerance { velocity ...; });
            // absent: 0, the relative test only (docs/coupler.md)
            const dictionary atol
            (
                dict_.subOrEmptyDict("absoluteTolerance")
            );
            for (const word& f : readFields_)
            {
                c.fields.push_back
                (
                    {
                        meshName_, f, 3, partner,
                        ::tq::coupler::MapConstraint::Consistent,
                        atol.lookupOrDefault<scalar>(f, 0)
                    }
                );
            }
            for (const word& f : writeFields_)
            {
                c.fields.push_back
                (
                    {
                        meshName_, f, 3, name_,
                        ::tq::coupler::MapConstraint::Conservative,
                        atol.lookupOrDefault<scalar>(f, 0)
                    }
                );
            }
            c.validate();

            // Transport: TCP (the MPI transport needs the world split of
            // an MPMD start, which OpenFOAM's Pstream does not offer)
            const word transport
            (
                dict_.lookupOrDefault<word>("transport", "tcp")
            );
            if (transport != "tcp")
            {
                fail
                (
                    "initialize",
                    "transport '" + transport + "': the OpenFOAM side speaks"
                    " tcp only (set 'transport tcp;')"
                );
            }
            t.addressFile =
                str(dict_.lookupOrDefault<fileName>("addressFile", "").expand());
            t.receiveTimeout = dict_.lookupOrDefault<scalar>("timeout", 120);
            t.connectTimeout =
                dict_.lookupOrDefault<scalar>("connectTimeout", 120);
            t.connectHost =
                str(dict_.lookupOrDefault<string>("host", "127.0.0.1"));
            t.connectPort = dict_.lookupOrDefault<label>("port", 0);
            const word role(dict_.lookupOrDefault<word>("role", "auto"));
            if (role == "listen")
            {
                t.role = ::tq::coupler::ConnectRole::Listen;
            }
            else if (role == "connect")
            {
                t.role = ::tq::coupler::ConnectRole::Connect;
            }
            else if (role != "auto")
            {
                fail("initialize", "role '" + role + "': auto, listen or connect");
            }
            if (t.addressFile.empty() && t.connectPort <= 0)
            {
                fail
                (
                    "initialize",
                    "no 'addressFile' (or 'port') to find the partner"
                );
            }
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("the coupling configuration", e.what());
        }

        // The run token: from the dictionary or the environment
        std::string token = str(dict_.lookupOrDefault<string>("token", ""));
        if (token.empty())
        {
            const word env
            (
                dict_.lookupOrDefault<word>("tokenEnv", "TQ_COUPLING_TOKEN")
            );
            token = str(Foam::getEnv(env));
            if (token.empty())
            {
                fail
                (
                    "initialize",
                    "no run token: give 'token' in the exchange dictionary"
                    " or set the environment variable " + env
                );
            }
        }

        try
        {
            participant_.reset
            (
                new ::tq::coupler::Participant(name_, c, t, token)
            );
            if (parts_)
            {
                participant_->setPart
                (
                    Pstream::myProcNo(),
                    Pstream::nProcs(),
                    std::make_shared<PstreamGroup>()
                );
            }
            participant_->setMeshVertices(meshName_, ids, xyz);
            if (resumeState_.empty())
            {
                participant_->initialize();
            }
            else
            {
                participant_->initializeResumed
                (
                    std::vector<unsigned char>
                    (
                        resumeState_.begin(),
                        resumeState_.end()
                    )
                );
            }
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("initialize (connect, handshake)", e.what());
        }

        Info<< "couplerExchange: participant '" << name_ << "' coupled with '"
            << partner << "' on mesh '" << meshName_ << "' ("
            << nGlobal_ << " points";
        if (parts_)
        {
            Info<< " in " << Pstream::nProcs() << " parts, one a rank, "
                << ownedLocal_.size() << " on the master, against "
                << label(participant_->partnerParts()) << " parts of '"
                << partner << "'";
        }
        Info<< "), scheme "
            << ::tq::coupler::schemeName(c.scheme) << ", window "
            << windowSize_ << " s x " << label(c.maxWindows) << endl;
        const ::tq::coupler::ExchangeStats xs = participant_->stats();
        waitAtStart_ = xs.secondsWaiting;
        mappingAtStart_ = xs.secondsMapping;
    }

    syncFlags();
    clockLast_ = wallNow();
}


void Foam::tq::couplerExchange::writeForces
(
    const scalar,
    const vectorField& forces
)
{
    enterCall();
    if (parts_)
    {
        // The shared points' partial forces to their owners, added there in
        // rank order from zero (the order of the gathered sum below)
        const label me = Pstream::myProcNo();
        PstreamBuffers bufs(Pstream::commsTypes::nonBlocking);
        sendSublists(bufs, forces, sendTo_);
        vectorField owned(ownedLocal_.size(), Zero);
        for (label proci = 0; proci < Pstream::nProcs(); ++proci)
        {
            if (proci == me)
            {
                forAll(ownedLocal_, k)
                {
                    owned[k] += forces[ownedLocal_[k]];
                }
                continue;
            }
            UIPstream is(proci, bufs);
            vectorField part(is);
            forAll(part, j)
            {
                owned[recvFrom_[proci][j]] += part[j];
            }
        }
        std::vector<double> f(3*owned.size());
        forAll(owned, k)
        {
            f[3*k] = owned[k].x();
            f[3*k + 1] = owned[k].y();
            f[3*k + 2] = owned[k].z();
        }
        try
        {
            participant_->writeData(meshName_, writeFields_[0], f);
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("writeData", e.what());
        }
        leaveCall();
        return;
    }
    // Point forces of all ranks, summed per global point (shared points
    // carry partial sums on each rank)
    List<labelList> procIds(Pstream::nProcs());
    List<vectorField> procF(Pstream::nProcs());
    procIds[Pstream::myProcNo()] = pointToGlobal_;
    procF[Pstream::myProcNo()] = forces;
    Pstream::gatherList(procIds);
    Pstream::gatherList(procF);

    if (Pstream::master())
    {
        std::vector<double> f(3*nGlobal_, 0.0);
        forAll(procIds, proci)
        {
            forAll(procIds[proci], i)
            {
                const label g = procIds[proci][i];
                const vector& F = procF[proci][i];
                f[3*g] += F.x();
                f[3*g + 1] += F.y();
                f[3*g + 2] += F.z();
            }
        }
        try
        {
            participant_->writeData(meshName_, writeFields_[0], f);
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("writeData", e.what());
        }
    }
    leaveCall();
}


void Foam::tq::couplerExchange::advance(const scalar dt)
{
    enterCall();
    ++passes_;
    bool complete = false;
    scalar windowStart = windowStart_;
    if (holds())
    {
        try
        {
            participant_->advance(dt);
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("advance", e.what());
        }
        complete = participant_->isTimeWindowComplete();
        windowStart = startTime_ + participant_->windowStartTime();
    }
    if (!parts_)
    {
        Pstream::scatter(complete);
        Pstream::scatter(windowStart);
    }
    syncFlags();

    if (complete)
    {
        ++windowsDone_;
        // The window is accepted: the next one starts from here
        windowDisplacement_ = lastDisplacement_;
        windowStart_ = windowStart;
    }
    leaveCall();
}


void Foam::tq::couplerExchange::readMotion
(
    const scalar t,
    vectorField& displacement,
    vectorField& velocity
)
{
    enterCall();
    velocity = readLocal("velocity");
    if (readsDisplacement_)
    {
        displacement = readLocal("displacement");
    }
    else
    {
        // u = u_w + v (t - t_w): the velocity is held over the window
        displacement = windowDisplacement_ + velocity*(t - windowStart_);
    }
    lastDisplacement_ = displacement;
    leaveCall();
}


void Foam::tq::couplerExchange::finalize()
{
    if (finalized_)
    {
        return;
    }
    finalized_ = true;
    reportCost();
    if (holds() && participant_)
    {
        try
        {
            participant_->finalize();
        }
        catch (const ::tq::coupler::CouplerError& e)
        {
            fail("finalize", e.what());
        }
    }
    ongoing_ = false;
}


namespace
{

template<class T>
void putRaw(std::string& s, const T& v)
{
    s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

template<class T>
bool getRaw(const std::string& s, size_t& pos, T& v)
{
    if (pos + sizeof(T) > s.size())
    {
        return false;
    }
    std::memcpy(&v, s.data() + pos, sizeof(T));
    pos += sizeof(T);
    return true;
}

void putVectors(std::string& s, const Foam::vectorField& f)
{
    putRaw<std::int64_t>(s, f.size());
    s.append
    (
        reinterpret_cast<const char*>(f.cdata()),
        f.size()*sizeof(Foam::vector)
    );
}

bool getVectors(const std::string& s, size_t& pos, Foam::vectorField& f)
{
    std::int64_t n = 0;
    if (!getRaw(s, pos, n) || n < 0 || pos + n*sizeof(Foam::vector) > s.size())
    {
        return false;
    }
    f.setSize(Foam::label(n));
    if (n)
    {
        std::memcpy(f.data(), s.data() + pos, n*sizeof(Foam::vector));
    }
    pos += n*sizeof(Foam::vector);
    return true;
}

} // End anonymous namespace


std::string Foam::tq::couplerExchange::saveState() const
{
    // On ranks: this rank's state (its points' motion; in parts its part of
    // the participant, gathered: the master's participant only); the
    // function object writes every rank's into one file
    std::string s;
    putRaw<std::int64_t>(s, windowsDone_);
    putRaw(s, windowStart_);
    putRaw<std::int64_t>(s, passes_);
    putVectors(s, windowDisplacement_);
    putVectors(s, lastDisplacement_);
    std::vector<unsigned char> bytes;
    try
    {
        if (holds() && participant_)
        {
            bytes = participant_->saveState();
        }
    }
    catch (const ::tq::coupler::CouplerError& e)
    {
        fail("saveState", e.what());
    }
    putRaw<std::int64_t>(s, std::int64_t(bytes.size()));
    s.append(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    return s;
}


void Foam::tq::couplerExchange::initializeResumed
(
    const polyPatch& patch,
    const pointField& points0,
    const scalarField& pointAreas,
    const std::string& state
)
{
    size_t pos = 0;
    std::int64_t windows = 0, passes = 0, n = 0;
    scalar windowStart = 0;
    vectorField windowDisplacement, lastDisplacement;
    if
    (
        !getRaw(state, pos, windows)
     || !getRaw(state, pos, windowStart)
     || !getRaw(state, pos, passes)
     || !getVectors(state, pos, windowDisplacement)
     || !getVectors(state, pos, lastDisplacement)
     || !getRaw(state, pos, n)
     || n < 0
     || pos + size_t(n) != state.size()
     || windowDisplacement.size() != points0.size()
    )
    {
        FatalErrorInFunction
            << "The exchange's restart state is damaged or belongs to"
            << " another interface." << exit(FatalError);
    }
    if ((n > 0) != holds())
    {
        // a participant's saved bytes exactly where this run holds one
        FatalErrorInFunction
            << "The exchange's restart state of rank " << Pstream::myProcNo()
            << (n > 0 ? " holds" : " holds no")
            << " coupler state, and this rank "
            << (holds() ? "holds" : "holds no") << " part of the participant:"
            << " the checkpoint was written with the water's ranks "
            << (n > 0 ? "in parts" : "gathered") << " (TQ_WATER_GATHER)."
            << nl << "Fix: resume with the water's ranks as they ran, or run"
            << " again without --resume." << exit(FatalError);
    }
    resumeState_ = state.substr(pos);
    initialize(patch, points0, pointAreas);
    resumeState_.clear();
    windowsDone_ = label(windows);
    windowStart_ = windowStart;
    passes_ = label(passes);
    windowDisplacement_ = windowDisplacement;
    lastDisplacement_ = lastDisplacement;
}


// ************************************************************************* //
