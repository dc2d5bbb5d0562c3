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

#include "fieldCheckpoint.H"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include "volFields.H"
#include "surfaceFields.H"
#include "pointFields.H"
#include "valuePointPatchField.H"
#include "tqProjected.H"
#include "lduPrimitiveMesh.H"
#include "pairGAMGAgglomeration.H"

#include <algorithm>

// * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
namespace
{

// Storage behind a patch field, or nullptr where the patch type holds none.
// fv and fvs patch fields are Fields; point patch fields only when they hold
// values (fixedValue and the like).

template<class Type>
Field<Type>* patchStorage(fvPatchField<Type>& pf)
{
    return &pf;
}

template<class Type>
Field<Type>* patchStorage(fvsPatchField<Type>& pf)
{
    return &pf;
}

template<class Type>
Field<Type>* patchStorage(pointPatchField<Type>& pf)
{
    return dynamic_cast<valuePointPatchField<Type>*>(&pf);
}


// Raw values of a restart file (this machine's byte order)

template<class T>
void put(std::ostream& os, const T& v)
{
    os.write(reinterpret_cast<const char*>(&v), sizeof(T));
}

template<class T>
void get(std::istream& is, T& v)
{
    if (!is.read(reinterpret_cast<char*>(&v), sizeof(T)))
    {
        FatalErrorInFunction
            << "The water's restart checkpoint ends early (a damaged file)."
            << exit(FatalError);
    }
}

void putWord(std::ostream& os, const std::string& w)
{
    put<std::int64_t>(os, std::int64_t(w.size()));
    os.write(w.data(), std::streamsize(w.size()));
}

word getWord(std::istream& is)
{
    std::int64_t n = 0;
    get(is, n);
    if (n < 0 || n > 4096)
    {
        FatalErrorInFunction
            << "The water's restart checkpoint is damaged (a name of " << n
            << " characters)." << exit(FatalError);
    }
    std::string w(size_t(n), ' ');
    if (n && !is.read(&w[0], std::streamsize(n)))
    {
        FatalErrorInFunction
            << "The water's restart checkpoint ends early (a damaged file)."
            << exit(FatalError);
    }
    return word(w, false);
}

template<class Type>
void putField(std::ostream& os, const Field<Type>& f)
{
    put<std::int64_t>(os, std::int64_t(f.size()));
    os.write
    (
        reinterpret_cast<const char*>(f.cdata()),
        std::streamsize(f.size()*sizeof(Type))
    );
}

template<class Type>
void getField(std::istream& is, Field<Type>& f)
{
    std::int64_t n = 0;
    get(is, n);
    if (n < 0 || n > (std::int64_t(1) << 34))
    {
        FatalErrorInFunction
            << "The water's restart checkpoint is damaged (a field of " << n
            << " values)." << exit(FatalError);
    }
    f.setSize(label(n));
    if
    (
        n
     && !is.read
        (
            reinterpret_cast<char*>(f.data()),
            std::streamsize(n*sizeof(Type))
        )
    )
    {
        FatalErrorInFunction
            << "The water's restart checkpoint ends early (a damaged file)."
            << exit(FatalError);
    }
}


// GAMG's pair agglomerator (the default faceAreaPair) walks the cells of
// each level it builds forwards or backwards by a process-wide flag that
// every level built flips (pairGAMGAgglomeration::forward_, private).  A
// moving mesh builds its agglomeration anew after every motion, so the
// abandoned attempt of a rolled-back step flips the flag, and the re-solved
// step would be agglomerated the other way: another multigrid, another
// answer within the solver tolerance.  The flag is read and set through the
// public per-level agglomerate() on a chain of five cells, which it pairs
// (0 1)(2 3 4) walking forwards and (0 1 2)(3 4) backwards.

//- Build one level on the chain: the flag before (true: forwards); flips it
bool flipPairAgglomerationDirection()
{
    labelList lower({0, 1, 2, 3});
    labelList upper({1, 2, 3, 4});
    const lduPrimitiveMesh chain(5, lower, upper, UPstream::worldComm, true);
    label nCoarse = 0;
    const tmp<labelField> cluster =
        pairGAMGAgglomeration::agglomerate
        (
            nCoarse,
            chain.lduAddr(),
            scalarField(4, 1.0)
        );
    return cluster()[2] == cluster()[4];
}

//- The flag, left as it was
bool pairAgglomerationForward()
{
    const bool forward = flipPairAgglomerationDirection();
    if (flipPairAgglomerationDirection() == forward)
    {
        FatalErrorInFunction
            << "GAMG's pair agglomeration did not change direction between"
            << " two builds (another OpenFOAM than v1912?): the rollback"
            << " cannot put its direction back." << exit(FatalError);
    }
    return forward;
}


//- A saved GeometricField: internal and boundary values
template<class GeoField>
class savedGeoField
:
    public savedObject
{
    typedef typename GeoField::value_type Type;

    word name_;
    Field<Type> internal_;
    List<Field<Type>> patches_;
    boolList hasPatch_;

public:

    explicit savedGeoField(const GeoField& fld)
    :
        name_(fld.name()),
        internal_(),
        patches_(),
        hasPatch_()
    {
        copy(fld);
    }

    //- Take the current values of fld (the same field, or a new one of the
    //  same name); storage of unchanged size is reused, not reallocated
    void copy(const GeoField& fld)
    {
        internal_ = fld.primitiveField();

        // Read the boundary without triggering the old-time bookkeeping
        GeoField& f = const_cast<GeoField&>(fld);
        auto& bf = f.boundaryFieldRef(false);
        patches_.setSize(bf.size());
        hasPatch_.setSize(bf.size());
        forAll(bf, patchi)
        {
            const Field<Type>* s = patchStorage(bf[patchi]);
            hasPatch_[patchi] = bool(s);
            if (s)
            {
                patches_[patchi] = *s;
            }
            else
            {
                patches_[patchi].clear();
            }
        }
    }

    //- Read back what write() wrote after the type tag
    savedGeoField(const word& name, std::istream& is)
    :
        name_(name)
    {
        getField(is, internal_);
        std::int64_t n = 0;
        get(is, n);
        patches_.setSize(label(n));
        hasPatch_.setSize(label(n));
        forAll(patches_, patchi)
        {
            std::uint8_t has = 0;
            get(is, has);
            hasPatch_[patchi] = has;
            getField(is, patches_[patchi]);
        }
    }

    virtual const word& name() const
    {
        return name_;
    }

    virtual bool create(const objectRegistry& obr) const
    {
        if (obr.foundObject<GeoField>(name_))
        {
            return true;
        }
        // An old-time level: made by its field's oldTime(), as the run
        // that saved it made it
        const std::string n(name_);
        if (n.size() < 3 || n.compare(n.size() - 2, 2, "_0") != 0)
        {
            return false;
        }
        const GeoField* base =
            obr.getObjectPtr<GeoField>(word(n.substr(0, n.size() - 2)));
        if (!base)
        {
            return false;
        }
        base->oldTime();
        return obr.foundObject<GeoField>(name_);
    }

    virtual void write(std::ostream& os) const
    {
        putWord(os, GeoField::typeName);
        putWord(os, name_);
        putField(os, internal_);
        put<std::int64_t>(os, patches_.size());
        forAll(patches_, patchi)
        {
            put<std::uint8_t>(os, hasPatch_[patchi] ? 1 : 0);
            putField(os, patches_[patchi]);
        }
    }

    virtual bool restore(const objectRegistry& obr) const
    {
        GeoField* fldPtr = obr.getObjectPtr<GeoField>(name_);
        if (!fldPtr)
        {
            return false;
        }
        GeoField& fld = *fldPtr;
        if (fld.primitiveField().size() != internal_.size())
        {
            FatalErrorInFunction
                << "Field " << name_ << " has " << fld.primitiveField().size()
                << " values, its checkpoint " << internal_.size()
                << ": the checkpoint belongs to another mesh."
                << exit(FatalError);
        }

        // Raw copies: 'false' keeps OpenFOAM from storing old-time levels
        // at this (unchanged) time index.
        fld.primitiveFieldRef(false) = internal_;
        auto& bf = fld.boundaryFieldRef(false);
        forAll(bf, patchi)
        {
            Field<Type>* s = patchStorage(bf[patchi]);
            if (s && hasPatch_[patchi])
            {
                *s = patches_[patchi];
            }
        }
        return true;
    }
};


//- A saved projection basis of the tqProjected linear solver
class savedProjection
:
    public savedObject
{
    word name_;
    scalar sign_;
    std::vector<scalarField> q_;

public:

    explicit savedProjection(const projectionHistory& h)
    :
        name_(h.name())
    {
        copy(h);
    }

    //- Read back what write() wrote after the type tag
    savedProjection(const word& name, std::istream& is)
    :
        name_(name),
        sign_(0)
    {
        get(is, sign_);
        std::int64_t n = 0;
        get(is, n);
        q_.resize(size_t(n));
        for (scalarField& q : q_)
        {
            getField(is, q);
        }
    }

    void copy(const projectionHistory& h)
    {
        sign_ = h.sign;
        q_ = h.q;
    }

    virtual const word& name() const
    {
        return name_;
    }

    virtual bool create(const objectRegistry& obr) const
    {
        // as tqProjected makes it at its first solve
        projectionHistory::lookupOrStore(obr, name_);
        return true;
    }

    virtual void write(std::ostream& os) const
    {
        putWord(os, projectionHistory::typeName);
        putWord(os, name_);
        put(os, sign_);
        put<std::int64_t>(os, std::int64_t(q_.size()));
        for (const scalarField& q : q_)
        {
            putField(os, q);
        }
    }

    virtual bool restore(const objectRegistry& obr) const
    {
        projectionHistory* h = obr.getObjectPtr<projectionHistory>(name_);
        if (!h)
        {
            return false;
        }
        h->sign = sign_;
        h->q = q_;
        return true;
    }
};

//- A saved object of type `type` named `name`, read from a restart file
savedObject* readSaved(const word& type, const word& name, std::istream& is)
{
    #define tqReadSaved(GeoField)                                              \
        if (type == GeoField::typeName)                                        \
        {                                                                      \
            return new savedGeoField<GeoField>(name, is);                      \
        }
    tqReadSaved(volScalarField)
    tqReadSaved(volVectorField)
    tqReadSaved(volSymmTensorField)
    tqReadSaved(volTensorField)
    tqReadSaved(surfaceScalarField)
    tqReadSaved(surfaceVectorField)
    tqReadSaved(surfaceSymmTensorField)
    tqReadSaved(surfaceTensorField)
    tqReadSaved(pointScalarField)
    tqReadSaved(pointVectorField)
    #undef tqReadSaved
    if (type == projectionHistory::typeName)
    {
        return new savedProjection(name, is);
    }
    FatalErrorInFunction
        << "The water's restart checkpoint holds an object " << name
        << " of unknown type " << type << " (written by another build)."
        << exit(FatalError);
    return nullptr;
}

} // End anonymous namespace
} // End namespace tq
} // End namespace Foam


// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
    defineTypeNameAndDebug(fieldCheckpoint, 0);
}
}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

template<class Object, class Saved>
bool Foam::tq::fieldCheckpoint::storeObject
(
    const regIOobject& obj,
    std::vector<bool>& seen,
    const bool isObject
)
{
    const Object* fldPtr =
        isObject
      ? static_cast<const Object*>(&obj)
      : dynamic_cast<const Object*>(&obj);
    if (!fldPtr)
    {
        return false;
    }

    // Saved before under this name and type: copy into that storage
    const auto iter = slots_.cfind(obj.name());
    if (iter.found())
    {
        Saved* s = dynamic_cast<Saved*>(&fields_[*iter]);
        if (s)
        {
            s->copy(*fldPtr);
            seen[*iter] = true;
            return true;
        }
        fields_.set(*iter, new Saved(*fldPtr));
        seen[*iter] = true;
        return true;
    }

    const label slot = fields_.size();
    fields_.append(new Saved(*fldPtr));
    slots_.set(obj.name(), slot);
    seen.resize(slot + 1, false);
    seen[slot] = true;
    return true;
}


template<class GeoField>
bool Foam::tq::fieldCheckpoint::storeField
(
    const regIOobject& obj,
    std::vector<bool>& seen,
    const bool isObject
)
{
    return storeObject<GeoField, savedGeoField<GeoField>>(obj, seen, isObject);
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tq::fieldCheckpoint::fieldCheckpoint(const fvMesh& mesh)
:
    mesh_(mesh),
    valid_(false),
    time_(0),
    deltaT_(0),
    timeIndex_(-1),
    fields_(),
    slots_(),
    gamgForward_(true),
    moving_(false)
{}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::tq::fieldCheckpoint::store()
{
    const Time& runTime = mesh_.time();
    time_ = runTime.value();
    deltaT_ = runTime.deltaTValue();
    timeIndex_ = runTime.timeIndex();

    // Every registered field of the saved types, in one pass over the
    // registry.  A field saved at the previous store is copied into its
    // storage (a coupled run stores every window: allocating and looking up
    // each field by type anew cost 0.1 ms a window on the 336-cell slice);
    // fields that no longer exist are dropped, new ones added.
    // The savers, tried in this order on an object of a type not seen
    // before; the first that takes it saves every later object of its type
    // (whether one takes an object depends on its dynamic type alone; up to
    // eleven dynamic_casts an object each store were 7 % of tqInterface's
    // work a pass on the slice, 0.31 M of a store's 0.37 M instructions)
    typedef bool (fieldCheckpoint::*saver)
    (
        const regIOobject&,
        std::vector<bool>&,
        bool
    );
    static const saver savers[] =
    {
        &fieldCheckpoint::storeField<volScalarField>,
        &fieldCheckpoint::storeField<volVectorField>,
        &fieldCheckpoint::storeField<volSymmTensorField>,
        &fieldCheckpoint::storeField<volTensorField>,
        &fieldCheckpoint::storeField<surfaceScalarField>,
        &fieldCheckpoint::storeField<surfaceVectorField>,
        &fieldCheckpoint::storeField<surfaceSymmTensorField>,
        &fieldCheckpoint::storeField<surfaceTensorField>,
        &fieldCheckpoint::storeField<pointScalarField>,
        &fieldCheckpoint::storeField<pointVectorField>,
        &fieldCheckpoint::storeObject<projectionHistory, savedProjection>
    };
    const int nSavers = int(sizeof(savers)/sizeof(savers[0]));

    std::vector<bool> seen(fields_.size(), false);
    forAllConstIters(mesh_.thisDb(), iter)
    {
        const regIOobject& obj = *iter.val();
        const std::type_index type(typeid(obj));
        const auto known = saverOfType_.find(type);
        if (known != saverOfType_.end())
        {
            if (known->second >= 0)
            {
                (this->*savers[known->second])(obj, seen, true);
            }
            continue;
        }
        int taker = -1;
        for (int k = 0; k < nSavers; ++k)
        {
            if ((this->*savers[k])(obj, seen, false))
            {
                taker = k;
                break;
            }
        }
        saverOfType_.emplace(type, taker);
    }
    if (std::find(seen.begin(), seen.end(), false) != seen.end())
    {
        PtrList<savedObject> kept(fields_.size());
        slots_.clear();
        label n = 0;
        forAll(fields_, i)
        {
            if (seen[i])
            {
                slots_.set(fields_[i].name(), n);
                kept.set
                (
                    n++,
                    fields_.set(i, static_cast<savedObject*>(nullptr))
                );
            }
        }
        kept.setSize(n);
        fields_.transfer(kept);
    }

    // Only a mesh that moves builds its agglomeration again after the first
    // solve; a static one (the transpiration interface) keeps it, so the
    // direction is neither read nor put back there
    if (mesh_.dynamic())
    {
        gamgForward_ = pairAgglomerationForward();
    }

    // Mesh motion state.  V0 and meshPhi exist once the mesh has moved.
    points_ = mesh_.points();
    moving_ = mesh_.moving() && runTime.timeIndex() > runTime.startTimeIndex();
    if (moving_)
    {
        fvMesh& mesh = const_cast<fvMesh&>(mesh_);
        V0_ = mesh.setV0();

        surfaceScalarField& meshPhi = mesh.setPhi();
        meshPhi_ = meshPhi.primitiveField();
        const auto& bf = meshPhi.boundaryFieldRef(false);
        meshPhiBf_.setSize(bf.size());
        forAll(bf, patchi)
        {
            meshPhiBf_[patchi] = bf[patchi];
        }

        // meshPhi_0: at this time index its access stores nothing
        const surfaceScalarField& meshPhi0 = meshPhi.oldTime();
        meshPhi0_ = meshPhi0.primitiveField();
        meshPhi0Bf_.setSize(bf.size());
        forAll(bf, patchi)
        {
            meshPhi0Bf_[patchi] = meshPhi0.boundaryField()[patchi];
        }
    }

    valid_ = true;

    if (debug)
    {
        Info<< "tq::fieldCheckpoint: stored " << fields_.size()
            << " fields at time " << time_ << endl;
        if (debug > 1)
        {
            forAll(fields_, i)
            {
                Info<< "    " << fields_[i].name() << endl;
            }
        }
    }
}


void Foam::tq::fieldCheckpoint::restore() const
{
    if (!valid_)
    {
        FatalErrorInFunction
            << "No checkpoint to restore: the partner asked for a rollback"
            << " before any state was saved (the exchange must ask for"
            << " writing a checkpoint first)." << exit(FatalError);
    }

    Time& runTime = const_cast<Time&>(mesh_.time());
    if (mag(runTime.deltaTValue() - deltaT_) > 1e-12*deltaT_)
    {
        FatalErrorInFunction
            << "Rollback with a changed time step (" << runTime.deltaTValue()
            << " s now, " << deltaT_ << " s when saved) is not supported."
            << nl << "Fix: use a fixed deltaT in coupled runs."
            << exit(FatalError);
    }

    // Time value back, step index kept increasing (see class description)
    runTime.setTime(time_, runTime.timeIndex());

    fvMesh& mesh = const_cast<fvMesh&>(mesh_);
    if (moving_)
    {
        // Same time index as the last motion: moves without shifting V0,
        // oldPoints or meshPhi_0; the swept-volume fluxes it computes are
        // overwritten below.
        mesh.movePoints(points_);
        mesh.setV0().field() = V0_;

        surfaceScalarField& meshPhi = mesh.setPhi();
        meshPhi.primitiveFieldRef(false) = meshPhi_;
        auto& bf = meshPhi.boundaryFieldRef(false);
        forAll(bf, patchi)
        {
            static_cast<scalarField&>(bf[patchi]) = meshPhiBf_[patchi];
        }
        surfaceScalarField& meshPhi0 = meshPhi.oldTime();
        meshPhi0.primitiveFieldRef(false) = meshPhi0_;
        auto& bf0 = meshPhi0.boundaryFieldRef(false);
        forAll(bf0, patchi)
        {
            static_cast<scalarField&>(bf0[patchi]) = meshPhi0Bf_[patchi];
        }
    }
    else if (mesh_.moving())
    {
        // Saved before the mesh first moved: back to the points of the
        // saved state, mesh at rest (no motion flux).  The next step stores
        // the current volumes as V0, as a fresh first step does.
        mesh.movePoints(points_);
        surfaceScalarField& meshPhi = mesh.setPhi();
        meshPhi.primitiveFieldRef(false) = 0;
        for (auto& pf : meshPhi.boundaryFieldRef(false))
        {
            static_cast<scalarField&>(pf) = 0;
        }
    }

    forAll(fields_, i)
    {
        if (!fields_[i].restore(mesh_))
        {
            WarningInFunction
                << "Field " << fields_[i].name() << " saved at time "
                << time_ << " no longer exists; not restored." << endl;
        }
    }

    if (mesh_.dynamic() && pairAgglomerationForward() != gamgForward_)
    {
        flipPairAgglomerationDirection();
    }

    // A projection basis made after the state was saved (a checkpoint
    // before the first pressure solve) was empty then: emptied, so that the
    // re-solved step starts as the first attempt did and not from the
    // abandoned attempt's increment
    forAllConstIters(mesh_.thisDb(), iter)
    {
        projectionHistory* h = dynamic_cast<projectionHistory*>(iter.val());
        if (h && !slots_.found(h->name()))
        {
            h->sign = 0;
            h->q.clear();
        }
    }

    if (debug)
    {
        Info<< "tq::fieldCheckpoint: restored " << fields_.size()
            << " fields to time " << time_ << " (saved at index "
            << timeIndex_ << ")" << endl;
    }
}


namespace
{
const char fieldCheckpointMagic[8] = {'T', 'Q', 'F', 'C', 'K', 'P', 'T', '1'};
}


void Foam::tq::fieldCheckpoint::write(std::ostream& os) const
{
    if (!valid_)
    {
        FatalErrorInFunction
            << "No state held to write." << exit(FatalError);
    }
    if (mesh_.moving())
    {
        FatalErrorInFunction
            << "A restart checkpoint of a moving mesh is not supported (the"
            << " mesh motion state is not written)." << nl
            << "Fix: interfaceMotion transpiration (a static mesh)."
            << exit(FatalError);
    }
    os.write(fieldCheckpointMagic, sizeof fieldCheckpointMagic);
    put(os, time_);
    put(os, deltaT_);
    put<std::int64_t>(os, timeIndex_);
    put<std::int64_t>(os, fields_.size());
    forAll(fields_, i)
    {
        fields_[i].write(os);
    }
}


void Foam::tq::fieldCheckpoint::readAndRestore(std::istream& is)
{
    char magic[sizeof fieldCheckpointMagic];
    if
    (
        !is.read(magic, sizeof magic)
     || std::memcmp(magic, fieldCheckpointMagic, sizeof magic) != 0
    )
    {
        FatalErrorInFunction
            << "Not a water field checkpoint (or a damaged one)."
            << exit(FatalError);
    }
    get(is, time_);
    get(is, deltaT_);
    std::int64_t index = 0, n = 0;
    get(is, index);
    timeIndex_ = label(index);
    get(is, n);
    fields_.clear();
    slots_.clear();
    fields_.setSize(label(n));
    for (label i = 0; i < label(n); ++i)
    {
        const word type(getWord(is));
        const word name(getWord(is));
        fields_.set(i, readSaved(type, name, is));
        slots_.set(name, i);
    }
    moving_ = false;
    points_ = mesh_.points();
    gamgForward_ = true;  // as at the saving run's first solve (static mesh)
    valid_ = true;

    // Old-time levels before the levels of those levels (U_0 before U_0_0)
    labelList order(fields_.size());
    forAll(order, i)
    {
        order[i] = i;
    }
    std::stable_sort
    (
        order.begin(),
        order.end(),
        [&](label a, label b)
        {
            return fields_[a].name().size() < fields_[b].name().size();
        }
    );
    wordList missing;
    for (const label i : order)
    {
        if (!fields_[i].create(mesh_))
        {
            missing.append(fields_[i].name());
        }
    }
    if (missing.size())
    {
        FatalErrorInFunction
            << "The water's restart checkpoint holds fields this run does not"
            << " have and cannot make: " << missing << nl
            << "Fix: resume with the same solver and case as the run that"
            << " wrote it, or run again without --resume."
            << exit(FatalError);
    }
    restore();
}


// ************************************************************************* //
